"""Diagnosis of the paper model's misfit: which physical effect(s) does it miss?

Given measured runs (sinusoidal current at several frequencies and amplitudes,
displacement y and, where measured, the sensing-coil voltage E), the workflow

1. **checks the magnitudes** against the paper's model before any fit
   (:func:`smeha.plausibility.check_plausible`: a column in the wrong unit is
   refused, naming it and the likely unit);
2. **reduces each usable run to features** (:mod:`smeha.diagnose.features`):
   harmonics of y and B referred to the current's phase, drift terms, B_m,
   noise from the data; a transient start is dropped only where the data show
   one; a run that cannot be used is skipped with its reason;
3. **fits the paper's model** (eq 30 in periodic steady state, the
   **continuous** mechanics of eq 27: the same measurement sampled at any
   rate gives the same answer) on the training runs, the four loss
   coefficients of eq 16 shared by all runs (:mod:`smeha.diagnose.fit`);
4. **characterises the residuals** (by branch, harmonic, frequency, drift;
   :func:`smeha.diagnose.report.characterise`);
5. **fits every candidate extension** (every form of every cause of
   :data:`gmt.extensions.REGISTRY`; :mod:`smeha.diagnose.candidates`) and
   scores it on the held-out runs (held-out chi^2 plus a BIC penalty);
6. **decides** (:mod:`smeha.diagnose.decision`): ``none`` within noise, else
   forward selection of one or more causes by the same rule, else
   ``unexplained``; parameters on their bounds make a weak finding;
7. **measures the gain**: held-out RMS error of y, paper over extended.

Default held-out runs: :func:`default_holdout`. The extended model is a
:class:`gmt.ModelVariant` (:meth:`Diagnosis.variant`, or
:func:`variant_from_diagnosis` of the JSON). SI inside; micrometres only in
the report. How to read it: docs/DIAGNOSE.md; the method and its limits: docs/DIAGNOSE-method.md.
"""
from ..measured import DataError
from . import progress
from .candidates import CAUSES, FORMS, PAPER, Batch, Candidate, Evaluator, candidates
from .decision import MAX_CAUSES
from .rules import MIN_BIC_DROP, MIN_EXPLAINED, WITHIN_NOISE
from .features import HARMONICS, MIN_CYCLES, RunFeatures, SkippedRun, run_features
from .fit import Fit
from .report import characterise, format_diagnosis, write_report
from .variant import read_variant, read_variant_json, variant_from_diagnosis
from .rules import CONFUSABLE_WITHOUT_B
from .workflow import (Diagnosis, default_holdout,
                       diagnose)

__all__ = [
    "DataError", "progress", "CAUSES", "FORMS", "PAPER", "Batch", "Candidate", "Evaluator",
    "candidates",
    "MAX_CAUSES", "MIN_BIC_DROP", "MIN_EXPLAINED", "WITHIN_NOISE", "HARMONICS", "MIN_CYCLES",
    "RunFeatures", "SkippedRun", "run_features", "Fit", "characterise", "format_diagnosis",
    "write_report", "read_variant", "read_variant_json", "variant_from_diagnosis",
    "CONFUSABLE_WITHOUT_B", "Diagnosis", "default_holdout", "diagnose",
]
