"""Mouth parameters of every corpus target (the 52 nuclei of the paper's Figure 3, and silence).

One row per target key of ``miketalk/data/corpus.tsv``. Targets the paper groups into one
viseme (section 4) share a pose, with small differences where the sounds differ (``s`` has the
tongue lower than ``t``; ``th`` pushes it between the teeth); different visemes get clearly
different poses. The pose of a key is a property of the face, not of the grouping: a
configured regrouping of the visemes does not change it.
"""

from __future__ import annotations

from synth_face.blendshapes import PARAM_NAMES

#: Column order of :data:`TARGETS` (also :data:`synth_face.blendshapes.PARAM_NAMES`).
COLUMNS = (
    "jaw_open", "lip_part", "lip_spread", "lip_round", "lip_press",
    "upper_lip_raise", "lower_lip_tuck", "tongue_tip", "tongue_out",
)  # fmt: skip
assert COLUMNS == PARAM_NAMES

# fmt: off
TARGETS: dict[str, tuple[float, ...]] = {
    #         jaw   part  spread round press raise tuck  t.tip t.out
    # --- silence: closed, relaxed, neutral
    "#":    (0.00, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),
    # --- viseme p {b, p, m}: lips closed and pressed
    "p":    (0.00, 0.00, 0.00, 0.00, 1.00, 0.00, 0.00, 0.00, 0.00),
    "b":    (0.00, 0.00, 0.00, 0.00, 1.00, 0.00, 0.00, 0.00, 0.00),
    "m":    (0.00, 0.00, 0.00, 0.00, 0.90, 0.00, 0.00, 0.00, 0.00),
    # --- viseme f {f, v}: lower lip tucked under the upper teeth
    "f":    (0.15, 0.00, 0.20, 0.00, 0.00, 0.80, 1.00, 0.00, 0.00),
    "v":    (0.15, 0.00, 0.20, 0.00, 0.00, 0.75, 0.95, 0.00, 0.00),
    # --- viseme t {t, d, s, z, th, dh}: teeth nearly closed, lips apart, tongue at the ridge;
    #     th, dh: tongue tip between the teeth
    "t":    (0.12, 0.55, 0.20, 0.00, 0.00, 0.10, 0.00, 1.00, 0.00),
    "d":    (0.12, 0.55, 0.20, 0.00, 0.00, 0.10, 0.00, 1.00, 0.00),
    "s":    (0.10, 0.58, 0.22, 0.00, 0.00, 0.12, 0.00, 0.75, 0.00),
    "z":    (0.10, 0.58, 0.22, 0.00, 0.00, 0.12, 0.00, 0.75, 0.00),
    "th":   (0.25, 0.50, 0.25, 0.00, 0.00, 0.10, 0.00, 0.00, 1.00),
    "dh":   (0.25, 0.50, 0.25, 0.00, 0.00, 0.10, 0.00, 0.00, 1.00),
    # --- viseme w {w, r}: rounded and protruded, small opening
    "w":    (0.05, 0.20, 0.00, 1.00, 0.00, 0.00, 0.00, 0.00, 0.00),
    "r":    (0.06, 0.22, 0.00, 0.92, 0.00, 0.03, 0.00, 0.20, 0.00),
    # --- viseme ch {ch, jh, sh, zh}: protruded lips, teeth close together and showing
    "ch":   (0.08, 0.75, 0.00, 0.55, 0.00, 0.35, 0.00, 0.30, 0.00),
    "jh":   (0.08, 0.75, 0.00, 0.55, 0.00, 0.35, 0.00, 0.30, 0.00),
    "sh":   (0.06, 0.75, 0.00, 0.60, 0.00, 0.35, 0.00, 0.20, 0.00),
    "zh":   (0.06, 0.75, 0.00, 0.60, 0.00, 0.35, 0.00, 0.20, 0.00),
    # --- viseme k {k, g, n, l, ng, h, y}: slightly open, relaxed: lips follow the jaw
    "k":    (0.45, 0.15, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),
    "g":    (0.45, 0.15, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),
    "ng":   (0.45, 0.15, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),
    "n":    (0.42, 0.15, 0.00, 0.00, 0.00, 0.00, 0.00, 0.50, 0.00),
    "l":    (0.45, 0.18, 0.00, 0.00, 0.00, 0.00, 0.00, 0.60, 0.00),
    "h":    (0.50, 0.20, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),
    "y":    (0.40, 0.15, 0.25, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),
    # --- viseme ii {ii, i}: spread
    "ii":   (0.10, 0.55, 1.00, 0.00, 0.00, 0.15, 0.00, 0.00, 0.00),
    "i":    (0.12, 0.55, 0.92, 0.00, 0.00, 0.12, 0.00, 0.00, 0.00),
    # --- viseme e {e, a}: mid open, spread
    "e":    (0.45, 0.70, 0.70, 0.00, 0.00, 0.05, 0.00, 0.00, 0.00),
    "a":    (0.55, 0.72, 0.65, 0.00, 0.00, 0.05, 0.00, 0.00, 0.00),
    # --- viseme aa {aa, o}: wide open
    "aa":   (1.00, 0.80, 0.10, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),
    "o":    (0.95, 0.80, 0.05, 0.10, 0.00, 0.00, 0.00, 0.00, 0.00),
    # --- viseme uh {uh, @, @@}: mid open, neutral, not spread
    "uh":   (0.60, 0.30, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),
    "@":    (0.55, 0.28, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),
    "@@":   (0.58, 0.30, 0.00, 0.20, 0.00, 0.00, 0.00, 0.10, 0.00),
    # --- viseme oo {oo}: open, rounded
    "oo":   (0.70, 0.60, 0.00, 0.55, 0.00, 0.00, 0.00, 0.00, 0.00),
    # --- viseme u {u}: medium round
    "u":    (0.30, 0.40, 0.00, 0.60, 0.00, 0.00, 0.00, 0.00, 0.00),
    # --- viseme uu {uu}: tight round
    "uu":   (0.12, 0.70, 0.00, 1.00, 0.00, 0.00, 0.00, 0.00, 0.00),
    # --- diphthongs: each nucleus near its viseme's pose
    "ou:1": (0.45, 0.55, 0.00, 0.80, 0.00, 0.00, 0.00, 0.00, 0.00),  # o-ou: round, open
    "ou:2": (0.28, 0.40, 0.00, 0.65, 0.00, 0.00, 0.00, 0.00, 0.00),  # u
    "ei:1": (0.45, 0.68, 0.68, 0.00, 0.00, 0.05, 0.00, 0.00, 0.00),  # e
    "ei:2": (0.12, 0.55, 0.92, 0.00, 0.00, 0.12, 0.00, 0.00, 0.00),  # ii
    "au:1": (0.95, 0.80, 0.10, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),  # aa
    "au:2": (0.20, 0.30, 0.00, 0.80, 0.00, 0.00, 0.00, 0.00, 0.00),  # w-au: rounded, small
    "ai:1": (0.95, 0.78, 0.10, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),  # aa
    "ai:2": (0.12, 0.55, 0.92, 0.00, 0.00, 0.12, 0.00, 0.00, 0.00),  # ii
    "oi:1": (0.65, 0.60, 0.00, 0.60, 0.00, 0.00, 0.00, 0.00, 0.00),  # oo
    "oi:2": (0.12, 0.55, 0.92, 0.00, 0.00, 0.12, 0.00, 0.00, 0.00),  # ii
    "e@:1": (0.48, 0.70, 0.65, 0.00, 0.00, 0.05, 0.00, 0.00, 0.00),  # e
    "e@:2": (0.58, 0.30, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),  # uh
    "i@:1": (0.12, 0.55, 0.92, 0.00, 0.00, 0.12, 0.00, 0.00, 0.00),  # ii
    "i@:2": (0.58, 0.30, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),  # uh
    "u@:1": (0.30, 0.40, 0.00, 0.60, 0.00, 0.00, 0.00, 0.00, 0.00),  # u
    "u@:2": (0.58, 0.30, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00, 0.00),  # uh
}
# fmt: on
