"""Step 10: synthetic corrected data, the hybrid on the DoE points and on samples drawn inside the support."""

from hybridtwin.io import files
from hybridtwin.io.files import read_checked
from hybridtwin.io.runner import run
from hybridtwin.paper import residual
from hybridtwin.paper.gate import KNNSupportGate
from hybridtwin.paper.hybrid import sample_in_support, synthetic_frame
from hybridtwin.paper.surrogate import GPRSurrogate


def main(snakemake):
    p = snakemake.params
    doe = read_checked(snakemake.input.doe)
    gate = KNNSupportGate.from_dict(files.read_json(snakemake.input.gate))
    surrogate = GPRSurrogate.from_dict(files.read_json(snakemake.input.surrogate))
    model = residual.load_model(snakemake.input.model)
    samples = sample_in_support(
        gate, doe[p.inputs].min().to_numpy(), doe[p.inputs].max().to_numpy(), p.n_samples, p.seed
    )
    outputs = {"doe": doe[p.inputs].to_numpy(float), "support": samples}
    for name, X in outputs.items():
        frame = synthetic_frame(X, p.inputs, surrogate, model, gate)
        if name == "doe":
            frame.insert(len(p.inputs), "simulated", doe[p.target].to_numpy(float))
        files.write_csv(frame, snakemake.output[name])


run(snakemake, main)
