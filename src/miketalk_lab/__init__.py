"""miketalk's laboratory: what measures the product, never part of it.

``evaluation`` (ground truth, flow error, morph fidelity, lip-sync and the
held-out comparisons), ``figures`` (plots and strips) and ``bench`` (``make
bench``'s timed measurements and cross-validations). It imports :mod:`miketalk`
and :mod:`synth_face`; neither imports it.
"""
