"""Rules figure_*: draw the figure ``params.figure`` names, from keyword inputs and params."""

from miketalk.stage import run_stage


def main() -> None:
    from miketalk_lab.figures.plots import draw

    settings = dict(snakemake.params.items())
    figure = settings.pop("figure")
    draw(figure, snakemake.output[0], **dict(snakemake.input.items()), **settings)


run_stage(snakemake, main)
