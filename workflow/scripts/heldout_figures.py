"""Rule figure_heldout: one test clip's eigenlip trajectory and mouth PSNR per frame."""

from pathlib import Path

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.figures.plots import heldout_psnr, heldout_trajectory

    p, frames = snakemake.params, snakemake.input.frames_csv
    timeline = Path(snakemake.input.videos) / f"{p.clip}.json"
    heldout_trajectory(frames, timeline, snakemake.output.trajectory, clip=p.clip, model=p.model)
    heldout_psnr(frames, snakemake.output.psnr, clip=p.clip, model=p.model)


run_stage(snakemake, main)
