"""Rules utterance and sweep_utterance: one text as an mp4 and its timeline JSON, through the
public API's ``say`` (:func:`miketalk.api.say`, the command line's and the page's call)."""

from miketalk.stage import run_stage


def main() -> None:
    from miketalk import api

    p = snakemake.params
    sampling, max_px = p.lipsync["sampling"], p.max_px
    if max_px is None or sampling == "none":  # the config's null: one morph a frame, no limit
        sampling, max_px = "none", None
    settings = api.SaySettings(
        model=snakemake.input.model,
        lipsync_model=p.lipsync["model"],
        trajectory=p.lipsync["trajectory"],
        sampling=sampling,
        max_px_per_frame=max_px,
        fps=p.fps,
        max_slowdown=p.lipsync["max_slowdown"],
        background=p.get("background", "still"),
        grouping=p.grouping or None,
    )
    models = api.OpenModels(1, morph=p.morph)  # the face's own morph settings
    try:
        api.say(p.text, snakemake.output.video, settings, models=models)
    finally:
        models.close()


run_stage(snakemake, main)
