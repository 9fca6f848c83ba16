"""The models the server lists: the workflow's, those named at start, those built on the page.

The page chooses a model by the id this list gives it (:meth:`Catalog.get`), never by a path.
The list is read again on each request (a model built meanwhile appears; a folder is a model
when it holds ``manifest.json``); what each model can do is read from its small files
(:mod:`miketalk.model.parts`), as ``miketalk say`` does before it starts.
"""

from __future__ import annotations

import json
import logging
import os
import re
import threading
from dataclasses import dataclass
from pathlib import Path

from miketalk.api import (
    MiketalkError,
    describe_model,
    is_model,
    model_picture,
    workflow_results,
)
from miketalk.serve.build import LABEL_FILE

log = logging.getLogger(__name__)

_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")


@dataclass(frozen=True)
class Entry:
    """One model of the list.

    Attributes
    ----------
    id : str
        What the page names it by.
    label : str
        What the page shows.
    path : Path
        Its folder (never sent to the page).
    source : str
        ``workflow`` (``results/model/*``), ``given`` (named at start) or ``built`` (on the
        page).
    """

    id: str
    label: str
    path: Path
    source: str

    def describe(self) -> dict:
        """What the page is told about it: what it can do, never where it is.

        Raises
        ------
        MiketalkError
            A model whose small files cannot be read.
        """
        info = describe_model(self.path)
        return {
            "id": self.id,
            "label": self.label,
            "source": self.source,
            "person": info.person,
            "lipsync_models": list(info.lipsync_models),
            "own_text": info.own_text,
            "own_recording": info.own_recording,
            "image": f"/api/models/{self.id}/image",
        }

    def image(self) -> Path | None:
        """A picture of the face: its person's first frame, else its rest viseme
        (:func:`miketalk.api.model_picture`)."""
        return model_picture(self.path)


def workflow_models() -> list[Path]:
    """The model folders the workflow made (``model/*`` in each of
    :func:`~miketalk.model.parts.workflow_results`), and ``$MIKETALK_MODEL``."""
    found: list[Path] = []
    for root in workflow_results():
        found += _models_under(root / "model")
    if env := os.environ.get("MIKETALK_MODEL"):
        found.append(Path(env))
    return found


def _models_under(root: Path) -> list[Path]:
    try:
        children = sorted(root.iterdir())
    except OSError:
        return []
    return [p for p in children if p.is_dir() and is_model(p)]


def built_label(model_dir: Path) -> str:
    """The label the page gave a model it built (its folder's name when there is none)."""
    try:
        doc = json.loads((model_dir / "build" / LABEL_FILE).read_text(encoding="utf-8"))
        label = str(doc["label"]).strip()
    except (OSError, ValueError, KeyError, TypeError):
        return model_dir.name
    return label or model_dir.name


class Catalog:
    """The models the server lists (see the module docstring).

    Parameters
    ----------
    built : Path
        Where the page's builds go.
    given : sequence of Path
        Models named at start.
    workflow : bool
        Also list :func:`workflow_models`.
    """

    def __init__(self, built: Path, given: tuple[Path, ...] = (), *, workflow: bool = True):
        self.built = built
        self.given = given
        self.workflow = workflow
        self._lock = threading.Lock()
        self._ids: dict[Path, str] = {}

    def entries(self) -> list[Entry]:
        """Every model now, each with the id it keeps while the server runs."""
        found: list[tuple[Path, str, str]] = []
        for path in self.given:
            found.append((path, "given", path.name))
        if self.workflow:
            found += [(p, "workflow", p.name) for p in workflow_models()]
        found += [(p, "built", built_label(p)) for p in _models_under(self.built)]
        entries, seen = [], set()
        for path, source, label in found:
            key = Path(os.path.realpath(path))
            if key in seen or not is_model(path):
                continue
            seen.add(key)
            entries.append(Entry(self._id_of(key, path.name), label, path, source))
        return entries

    def _id_of(self, key: Path, name: str) -> str:
        with self._lock:
            if key not in self._ids:
                base = _UNSAFE.sub("-", name).strip("-.") or "model"
                taken = set(self._ids.values())
                chosen, n = base, 1
                while chosen in taken:
                    n += 1
                    chosen = f"{base}-{n}"
                self._ids[key] = chosen
            return self._ids[key]

    def get(self, model_id: object) -> Entry:
        """The model called ``model_id`` in the list.

        Raises
        ------
        MiketalkError
            When the list has no such model.
        """
        for entry in self.entries():
            if entry.id == model_id:
                return entry
        raise MiketalkError("no such model: choose one from the list (it may have been removed)")

    def describe(self) -> list[dict]:
        """The list as the page sees it (a model whose files cannot be read is left out and
        logged)."""
        out = []
        for entry in self.entries():
            try:
                out.append(entry.describe())
            except (MiketalkError, OSError) as err:
                log.warning("model %s left out of the list: %s", entry.path, err)
        return out
