"""Write the demo plant's CSVs and its noise-free truth."""

from hybridtwin import demo
from hybridtwin.io import files
from hybridtwin.io.runner import run


def main(snakemake):
    plant = demo.plant_from_config(snakemake.params.demo)
    frames = demo.generate(plant)
    for name, path in snakemake.output.items():
        if name == "spec":
            files.write_json(demo.describe_plant(plant), path)
        else:
            files.write_csv(frames[name], path)


run(snakemake, main)
