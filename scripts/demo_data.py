"""Write the demo plant's CSVs and its noise-free truth."""
from hybridtwin import demo, io
from hybridtwin.runner import run


def main(snakemake):
    plant = demo.plant_from_config(snakemake.params.demo)
    frames = demo.generate(plant)
    for name, path in snakemake.output.items():
        if name == "spec":
            io.write_json(demo.describe_plant(plant), path)
        else:
            io.write_csv(frames[name], path)


run(snakemake, main)
