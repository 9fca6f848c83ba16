"""Rule figure_heldout: one test clip's eigenlip trajectory, mouth PSNR per frame, and a
strip of its side-by-side video around the mouth."""

from pathlib import Path

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.mouth import mouth_region
    from miketalk_lab.figures.heldout_strip import heldout_strip
    from miketalk_lab.figures.plots import heldout_psnr, heldout_trajectory

    p, frames, out = snakemake.params, snakemake.input.frames_csv, snakemake.output
    videos = Path(snakemake.input.videos)
    clip = p.clip or _first_clip(frames)  # a face from one video: its first test utterance
    timeline = videos / f"{clip}.json"
    heldout_trajectory(frames, timeline, out.trajectory, clip=clip, model=p.model)
    heldout_psnr(frames, out.psnr, clip=clip, model=p.model)
    heldout_strip(
        videos / f"{clip}.mp4",
        timeline,
        out.strip,
        mouth_box=mouth_region(Path(snakemake.input.regions).parent),
        scale=2.5,
    )


def _first_clip(frames_csv) -> str:
    import csv

    with open(frames_csv, newline="", encoding="utf-8") as f:
        return next(csv.DictReader(f))["clip"]


run_stage(snakemake, main)
