"""The plant quantities the structures generator draws from: their DoE ranges and roles, the names a plant may
give them, and the styles of its shift and coil labels."""

from __future__ import annotations

from collections import namedtuple

from hybridtwin.demo import families

MATERIAL, THERMAL, SETTING = "material", "thermal", "setting"


# a plant quantity: its DoE range, its role and the step it is set in (settings; 0: continuous)
Quantity = namedtuple("Quantity", "low high role step", defaults=(0.0,))
QUANTITIES = {
    "thickness_mm": Quantity(0.62, 0.82, MATERIAL),
    "rm_mpa": Quantity(280.0, 380.0, MATERIAL),
    "rp02_mpa": Quantity(160.0, 250.0, MATERIAL),
    "r_n": Quantity(1.4, 2.2, MATERIAL),
    "lubricant": Quantity(0.6, 2.6, MATERIAL),
    "die_temp_c": Quantity(15.0, 55.0, THERMAL),
    "ambient_temp_c": Quantity(5.0, 35.0, THERMAL),
    "oil_temp_c": Quantity(18.0, 50.0, THERMAL),
    **{f"shim{k}_mm": Quantity(0.0, 0.6, SETTING, 0.05) for k in (20, 21)},
    **{f"cushion_c{k}_kn": Quantity(150.0, 350.0, SETTING, 5.0) for k in range(1, 5)},
    "blank_holder_kn": Quantity(600.0, 1000.0, SETTING, 10.0),
    "press_speed_spm": Quantity(8.0, 20.0, SETTING, 1.0),
}
VOCABULARY = {
    **families.INPUT_VOCABULARY,
    **families.LOG_VOCABULARY,
    "blank_holder_kn": ("blank_holder_kn", "BHF", "niederhalterkraft", "bh_force"),
    "press_speed_spm": ("press_speed_spm", "SPM", "hubzahl", "stroke_rate"),
    "oil_temp_c": ("oil_temp_c", "T_oil", "oeltemp", "press_oil_temp"),
}
SHIFT_LABELS = (("A", "B", "C"), ("F", "S", "N"), ("early", "late", "night"))
COIL_STYLES = ("K{k:05d}", "C-{year}-{k:05d}", "{k:06d}-B", "L{lot:02d}/{k:05d}", "COIL_{k}")
RELATIONS = ("shorter", "equal", "longer")  # a coil's length against a setting campaign's


def of_role(role: str, names=QUANTITIES) -> list[str]:
    """The quantities of a role (material, thermal, setting) among ``names``."""
    return [name for name in names if QUANTITIES[name].role == role]
