"""Merge sync tables and summarise each sentence / setting in one row."""

from miketalk.stage import run_stage


def psnr_of_mean_mse(psnr):
    """PSNR of the mean squared error over frames (identical frames have infinite PSNR)."""
    import numpy as np

    mse = 255.0**2 / np.power(10.0, np.asarray(psnr, float) / 10.0)
    return float(10 * np.log10(255.0**2 / mse.mean())) if mse.mean() > 0 else float("inf")


def main() -> None:
    import numpy as np
    import pandas as pd

    from miketalk.media.atomic import write_text_atomic

    table = pd.concat([pd.read_csv(p, keep_default_na=False) for p in snakemake.input])
    write_text_atomic(snakemake.output.table, table.to_csv(index=False, float_format="%.6g"))
    rows = []
    keys = ["sentence", "fps", "max_px_per_frame"]
    for group, part in table.groupby(keys, sort=True):
        q = part.groupby("quantity")["value"]
        step = part[part["quantity"] == "largest_step_px"].set_index("key")["value"]
        offsets = part[part["quantity"] == "viseme_offset_frames"]["value"].abs()
        rows.append(
            dict(zip(keys, group, strict=True))
            | {
                "frames": int((part["quantity"] == "psnr_full").sum()),
                "psnr_mouth": psnr_of_mean_mse(q.get_group("psnr_mouth")),
                "psnr_full": psnr_of_mean_mse(q.get_group("psnr_full")),
                "identical_frames": int(np.isinf(q.get_group("psnr_full")).sum()),
                "mouth_lag_frames": q.get_group("mouth_lag_frames").iloc[0],
                "mouth_opening_corr": q.get_group("mouth_opening_corr").iloc[0],
                "max_abs_viseme_offset_frames": offsets.max(),
                "visemes_within_half_frame": float((offsets <= 0.5 + 1e-9).mean()),
                "largest_step_px_plain": step.get("plain"),
                "largest_step_px_oversampled": step.get("oversampled"),
                "audio_seconds": q.get_group("audio_seconds").iloc[0],
                "video_seconds": q.get_group("video_seconds").iloc[0],
                "duration_diff_frames": q.get_group("duration_diff_frames").iloc[0],
                "lengthened_seconds": q.get_group("lengthened_seconds").iloc[0],
            }
        )
    summary = pd.DataFrame(rows)
    write_text_atomic(snakemake.output.summary, summary.to_csv(index=False, float_format="%.4f"))


run_stage(snakemake, main)
