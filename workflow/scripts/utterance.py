"""Rules utterance and sweep_utterance: one text as an mp4 and its timeline JSON."""

from miketalk.stage import run_stage


def main() -> None:
    from miketalk.composite.for_model import resolve_background
    from miketalk.lipsync.settings import LipsyncSettings
    from miketalk.talk.say import open_model, say
    from miketalk.visemes import VisemeTable

    p = snakemake.params
    model = open_model(snakemake.input.model, morph_options=p.morph)
    settings = LipsyncSettings(
        fps=p.fps,
        max_px_per_frame=p.max_px,
        sampling=p.lipsync["sampling"],
        max_slowdown=p.lipsync["max_slowdown"],
        model=p.lipsync["model"],
        trajectory=p.lipsync["trajectory"],
    )
    say(
        p.text,
        snakemake.output.video,
        model=model,
        settings=settings,
        table=VisemeTable(grouping=p.grouping),
        background=resolve_background(p.get("background", "still"), model),
    )


run_stage(snakemake, main)
