"""Bad input, tried as a user would: spoilt videos given to ``miketalk dub`` and ``build``.

``python -m miketalk_lab.bench.bad_input --obama DIR --out OUT [--limit N] [--probe P ...]``

1. joins four weekly addresses of ``DIR`` (``video/waNN.mp4``, ``transcripts.txt``:
   :data:`ADDRESSES`, the four whose caption lines align) into one video with their sound
   and captions (``OUT/work/source.mp4``, ``source.txt``), and tracks its face;
2. makes the probes (:mod:`miketalk_lab.probe_videos`) from it: the face leaving the
   picture for 1.5 s (``leaves``), the head turned to a profile and back (``turn``) or
   turned all along (``profile``), the picture rolled 90 degrees (``roll``), two faces
   side by side (``two``), a second face coming in for 1.5 s (``second``); the spans
   are in the last address, from its 1.0 s to its 2.5 s. The joined video itself is the
   probe ``cut``: one address cut to another, three times;
3. gives each probe, through the installed ``miketalk`` in a subprocess, to ``miketalk
   build PROBE --transcript source.txt`` and to ``miketalk dub PROBE --audio PROBE -f
   source.txt --model M`` (the probe re-mouthed to its own sound), each in a folder of
   its own with ``TMPDIR`` one of its own. ``M`` is the ``cut`` probe's build: the model
   of the four addresses (reused when there);
4. records for each run (:mod:`miketalk_lab.bench.probe_checks`): the exit status, the
   ``miketalk:`` lines on stderr (a traceback is the probe's failure), the files in the
   run's folder and ``TMPDIR`` afterwards (anything but the output is left over), and, for
   a dub written, the frames left untouched (compared with the probe) against the frames
   its warning names and the frames the probe changed; for a model built, what its
   ``build/skipped.tsv`` names.

Writes ``OUT/probes.tsv`` (one row per probe and command), ``OUT/frames.tsv`` (every
frame of every dub written), ``OUT/summary.md`` and ``OUT/strip_PROBE.png`` per dub written
(a few frames: the probe above, the dub below, labelled), and prints the summary. Probe
videos, runs and the model stay under ``OUT/work`` (a probe is made again only if its mp4
is missing; every run is run again).
"""

from __future__ import annotations

import csv
import io
import json
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from miketalk import defaults
from miketalk.errors import MiketalkError
from miketalk.media.atomic import write_text_atomic
from miketalk_lab.bench.command import bench_parser, run_bench
from miketalk_lab.bench.probe_checks import (
    dub_frames,
    leftovers,
    named_frames,
    ranges,
    skipped_rows,
    stderr_lines,
    strip,
)
from miketalk_lab.probe_videos import PROBES, SPANNED, face_geometry, write_probe

#: The addresses joined, in order: the four whose caption lines align fully.
ADDRESSES = ("wa01", "wa05", "wa06", "wa08")
#: Where a spanned probe acts in the last address: from and to (seconds into it).
SPAN_S = (1.0, 2.5)
#: Every probe reported: the made ones, then the joined video itself.
ALL_PROBES = (*PROBES, "cut")
_RATE = 44100
_COLUMNS = (
    "probe", "command", "exit", "seconds", "traceback", "lines", "outputs", "left_over",
    "frames", "changed_by_probe", "untouched", "named", "untouched_not_named",
    "named_but_changed", "build_skipped",
)  # fmt: skip


def _miketalk() -> str:
    return str(Path(sys.executable).parent / "miketalk")


def join_addresses(
    obama: Path, work: Path, addresses: Sequence[str] = ADDRESSES, stem: str = "source"
) -> dict:
    """Join ``addresses`` (default :data:`ADDRESSES`) into ``work/STEM.mp4`` with
    ``STEM.txt`` (reused when there); return ``{"fps", "frames", "starts"}`` (each
    address's first frame)."""
    from miketalk.corpus.clip_sources import read_transcripts
    from miketalk.media.decode import iter_video_frames, read_media_audio, video_info
    from miketalk.media.video import write_mp4

    info = work / f"{stem}.json"
    if info.is_file() and (work / f"{stem}.mp4").is_file():
        return json.loads(info.read_text())
    captions = read_transcripts(obama / "transcripts.txt")
    paths = [obama / "video" / f"{a}.mp4" for a in addresses]
    for path in paths:
        if not path.is_file():
            raise MiketalkError(f"{path} not found: --obama is the weekly addresses' folder")
    fps = video_info(paths[0])[2]
    counts = [sum(1 for _ in iter_video_frames(p, grey=True)) for p in paths]
    sound = []
    for path, n in zip(paths, counts, strict=True):
        audio = read_media_audio(path, rate=_RATE)
        want = round(n / fps * _RATE)  # each address's sound fitted to its frames
        sound.append(np.pad(audio[:want], (0, max(0, want - len(audio)))))

    def frames():
        for path in paths:
            yield from iter_video_frames(path)

    work.mkdir(parents=True, exist_ok=True)
    write_mp4(work / f"{stem}.mp4", frames(), fps=fps, audio=np.concatenate(sound), rate=_RATE,
              n_frames=sum(counts), crf=16)  # fmt: skip
    write_text_atomic(work / f"{stem}.txt", "\n".join(captions[a] for a in addresses) + "\n")
    doc = {"fps": fps, "frames": sum(counts),
           "starts": [int(s) for s in np.cumsum([0, *counts[:-1]])]}  # fmt: skip
    write_text_atomic(info, json.dumps(doc))
    return doc


def make_probes(work: Path, source: dict, names: Sequence[str]) -> dict[str, list[int]]:
    """Each probe's mp4 in ``work/probes`` (made when missing); per probe the frames it
    changes (``cut``: the cuts' first frames)."""
    from miketalk.media.decode import iter_video_frames, read_media_audio
    from miketalk.track import track_video

    fps, n = source["fps"], source["frames"]
    last = source["starts"][-1]
    span = (last + round(SPAN_S[0] * fps), last + round(SPAN_S[1] * fps))
    geometry_file = work / "geometry.npy"
    if not geometry_file.is_file():
        np.save(geometry_file, face_geometry(track_video(work / "source.mp4")))
    geometry = np.load(geometry_file)
    audio = None
    changed: dict[str, list[int]] = {"cut": [int(s) for s in source["starts"][1:]]}
    for name in names:
        if name == "cut":
            continue
        path = work / "probes" / f"{name}.mp4"
        weights = np.zeros(n)
        weights[span[0] : span[1]] = 1.0
        if name not in SPANNED:
            weights[:] = 1.0
        if not path.is_file():
            if audio is None:
                audio = read_media_audio(work / "source.mp4", rate=_RATE)
            print(f"making the probe {name}", flush=True)
            weights = write_probe(
                path, name, lambda: iter_video_frames(work / "source.mp4"), geometry,
                fps=fps, audio=audio, rate=_RATE, span=span, other_offset=n // 2,
            )  # fmt: skip
        changed[name] = [int(k) for k in np.flatnonzero(weights > 0)]
    return changed


def _run(command: list[str], folder: Path) -> dict:
    """Run ``command`` in a fresh ``folder`` (its ``tmp`` the ``TMPDIR``); what happened."""
    shutil.rmtree(folder, ignore_errors=True)
    (folder / "tmp").mkdir(parents=True)
    env = dict(os.environ, TMPDIR=str(folder / "tmp"))
    started = time.perf_counter()
    proc = subprocess.run(command, capture_output=True, text=True, env=env, cwd=folder)
    seconds = time.perf_counter() - started
    (folder / "stderr.txt").write_text(proc.stderr)
    return {"command": command, "exit": proc.returncode, "seconds": round(seconds, 1),
            "stderr": proc.stderr}  # fmt: skip


def run_probe(name: str, work: Path, video: Path, model: Path, changed: list[int]) -> list[dict]:
    """``build`` then ``dub`` of one probe (the ``cut`` probe's build is the model's, kept
    and reused); their rows of ``probes.tsv``, the dub's per-frame rows under ``"frames"``."""
    rows = []
    transcript = work / "source.txt"
    for command in ("build", "dub"):
        folder = work / "runs" / name / command
        out = folder / ("model" if command == "build" else "dub.mp4")
        record = folder.parent / f"{command}.json"
        reuse = name == "cut" and command == "build" and record.is_file() and out.is_dir()
        if reuse:
            done = json.loads(record.read_text())
        else:
            if command == "build":
                args = ["build", str(video), "--transcript", str(transcript), "-o", str(out)]
            else:
                args = ["dub", str(video), "--audio", str(video), "-f", str(transcript),
                        "--model", str(model), "-o", str(out)]  # fmt: skip
            print(f"{name}: miketalk {command}", flush=True)
            done = _run([_miketalk(), *args], folder)
            record.write_text(json.dumps(done))
        lines, traceback = stderr_lines(done["stderr"])
        expected = {out.name, out.with_suffix(".json").name} if command == "dub" else {out.name}
        outputs, left = leftovers(folder, expected)
        row = {"probe": name, "command": f"miketalk {command}", "exit": done["exit"],
               "seconds": done["seconds"], "traceback": "yes" if traceback else "no",
               "lines": " | ".join(lines), "outputs": " ".join(outputs) or "-",
               "left_over": " ".join(left) or "-"}  # fmt: skip
        if command == "build" and out.is_dir():
            row["build_skipped"] = "; ".join(skipped_rows(out)) or "-"
        if command == "dub" and out.is_file():
            frames = dub_frames(video, out)
            named = named_frames(lines)
            untouched = {k for k, f in enumerate(frames) if not f["changed"]}
            row |= {
                "frames": len(frames), "changed_by_probe": ranges(changed),
                "untouched": ranges(untouched), "named": ranges(named),
                "untouched_not_named": ranges(untouched - named),
                "named_but_changed": ranges(named - untouched),
            }  # fmt: skip
            for k, f in enumerate(frames):
                f |= {"probe": name, "frame": k, "named": int(k in named),
                      "changed_by_probe": int(k in set(changed))}  # fmt: skip
            row["frames_detail"] = frames
            wide = 8.0 if name == "second" else 3.5  # the second face in the picture too
            strip(video, out, work.parent / f"strip_{name}.png", changed, named, frames,
                  np.load(work / "geometry.npy"), half_width=wide)  # fmt: skip
        rows.append(row)
    return rows


def run(obama: Path, out: Path, *, probes: Sequence[str] = ALL_PROBES) -> str:
    """Make the probes, run them, write ``probes.tsv``, ``frames.tsv``, ``summary.md`` and
    the strips; return the summary.

    Parameters
    ----------
    obama : pathlib.Path
        The weekly addresses' folder (``video/``, ``transcripts.txt``).
    out : pathlib.Path
        The output folder (its ``work`` keeps the probes, the runs and the model).
    probes : sequence of str
        Which of :data:`ALL_PROBES` (``cut`` always runs first: its build is the model).

    Returns
    -------
    str
        The markdown summary.
    """
    out, obama = out.resolve(), obama.resolve()  # the runs' working folders are their own
    work = out / "work"
    source = join_addresses(obama, work)
    changed = make_probes(work, source, probes)
    model = work / "runs" / "cut" / "build" / "model"
    rows: list[dict] = []
    for name in ("cut", *(p for p in probes if p != "cut")):
        video = work / "source.mp4" if name == "cut" else work / "probes" / f"{name}.mp4"
        found = run_probe(name, work, video, model, changed.get(name, []))
        if name == "cut" and not (model / "manifest.json").is_file():
            raise MiketalkError(f"the model of the four addresses was not built: {found[0]}")
        if name == "cut" and "cut" not in probes:
            continue
        rows += found
    _write_tables(out, rows)
    summary = _summary(out, source, rows)
    write_text_atomic(out / "summary.md", summary)
    return summary


def _write_tables(out: Path, rows: list[dict]) -> None:
    buffer = io.StringIO()
    writer = csv.writer(buffer, delimiter="\t", lineterminator="\n")
    writer.writerow(_COLUMNS)
    for row in rows:
        writer.writerow([row.get(c, "") for c in _COLUMNS])
    write_text_atomic(out / "probes.tsv", buffer.getvalue())
    frames = [f for row in rows for f in row.get("frames_detail", [])]
    keys = ("probe", "frame", "changed_px", "changed", "named", "changed_by_probe")
    buffer = io.StringIO()
    writer = csv.writer(buffer, delimiter="\t", lineterminator="\n")
    writer.writerow(keys)
    writer.writerows([f[k] for k in keys] for f in frames)
    write_text_atomic(out / "frames.tsv", buffer.getvalue())


def _summary(out: Path, source: dict, rows: list[dict]) -> str:
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True, cwd=Path(__file__).parent).stdout.strip()  # fmt: skip
    lines = [
        f"# Bad input: {len(rows) // 2} probes at {head or 'an unknown commit'}",
        "",
        f"The four addresses {', '.join(ADDRESSES)} joined ({source['frames']} frames at "
        f"{source['fps']:g} fps; cuts at frames {', '.join(map(str, source['starts'][1:]))});"
        " the probes made from it. `build`: `miketalk build PROBE --transcript source.txt`; "
        "`dub`: `miketalk dub PROBE --audio PROBE -f source.txt --model` (the `cut` probe's "
        "model).",
        "",
        "| probe | command | exit | s | traceback | stderr (miketalk: lines) | left over | "
        "frames the probe changed | untouched frames | named | untouched, not named | "
        "named, changed |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    frame_columns = ("changed_by_probe", "untouched", "named", "untouched_not_named",
                     "named_but_changed")  # fmt: skip
    for r in rows:
        lines.append(
            f"| {r['probe']} | {r['command']} | {r['exit']} | {r['seconds']} | "
            f"{r['traceback']} | {r['lines'].replace(' | ', '<br>') or '-'} | {r['left_over']} | "
            + " | ".join(r.get(c, "") or "-" for c in frame_columns)
            + " |"
        )
    failed = [r for r in rows if r["traceback"] == "yes" or r["left_over"] != "-"
              or r.get("untouched_not_named") or r.get("named_but_changed")]  # fmt: skip
    lines += ["", f"Runs with a traceback, a leftover or frames left out unnamed: {len(failed)} "
              f"of {len(rows)}"]  # fmt: skip
    lines += [f"- {r['probe']} {r['command']}" for r in failed]
    built = [r for r in rows if r.get("build_skipped")]
    lines += ["", "Models built, what `build/skipped.tsv` names:", ""]
    lines += [f"- {r['probe']}: {r['build_skipped']}" for r in built] or ["- none"]
    lines += ["", f"Strips: {', '.join(sorted(p.name for p in out.glob('strip_*.png'))) or '-'}"]
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """Make the bad-input probes, give them to ``miketalk build`` and ``dub``, report.

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments (``sys.argv[1:]`` by default).

    Returns
    -------
    int
        0 on success, 1 on a MiketalkError (printed on stderr).
    """
    parser = bench_parser(__name__, __doc__, limit_help="the first N probes only")
    parser.add_argument("--obama", type=Path, required=True, help="the weekly addresses' folder")
    parser.add_argument(
        "--out", type=Path, default=defaults.RESULTS / "bench" / "bad_input", help="output folder"
    )
    parser.add_argument("--probe", nargs="+", choices=ALL_PROBES, default=None,
                        help="only these probes")  # fmt: skip
    return run_bench(
        parser,
        argv,
        lambda a: run(a.obama, a.out, probes=tuple(a.probe or ALL_PROBES)[: a.limit]),
    )


if __name__ == "__main__":
    sys.exit(main())
