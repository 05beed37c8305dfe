"""The diagnosis' selection policy, in one place.

The statistical settings a user may change (folds, alpha, the blocks of the block test, the surrogate
margin) are in :class:`~hybridtwin.diagnosis.settings.Settings`, from the config's ``diagnosis:``.
"""

# numeric candidates are scored on held-out quantile bins of their own values, this many per fold:
# enough bins to spread each fold over the range, few enough that a bin holds whole campaigns
BINS_PER_FOLD = 4
# a simpler cause may explain this much less of the residual variance and still count as the same
SHARE_TOLERANCE = 0.05
# forms with at most this many parameters are closed forms (linear, quadratic, step, sigmoid, product);
# more (monotone trend, group offsets) take up the surrogate's own error too
MAX_CLOSED_FORM_PARAMS = 3
# elapsed time and a product of two columns count this many parameters more than they have: both stand
# for something else (what changes with time; one of the two columns)
PROXY_PENALTY = 0.5
# confounding: a chosen cause is tested both ways against the strongest rivals that explain at least this
# share of what it explains on its own, at most this many of them
RIVAL_SHARE = 0.5
MAX_RIVALS = 8
# a changed cause changes what the others are fitted to: go round again, a few times at most
REFINE_PASSES = 3
# an id that stands is still named after the smooth causes when they account for this share of its level
# differences held out by level (a wear or a lubricant that changes per coil, with offsets of the coil's own
# beside it); offsets no smooth quantity predicts are accounted for near 0
ID_ACCOUNTED_SMOOTH_FIRST = 0.25
# ... and where the best smooth column (not a product, which may stand for two coils' worth of offsets by chance)
# explains this share of what the id explains: a die temperature's saturation or a wear that the coil's offsets
# follow, and that a quadratic surface of the inputs cannot hold. Offsets nothing logged causes leave the best
# column a small share of the id's (at most 0.38 on the families' coil plants; 0.64 and more where a column is the
# cause)
SMOOTH_SHARE_OF_ID = 0.6
# a trend in time that parts run at the same settings do not show is not named where the test had this power to
# see it (against the trend as fitted, at the diagnosis' level); with less, the data cannot tell it from the
# settings that changed with time, and it is named as before
TREND_POWER = 0.9
