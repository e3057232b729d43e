"""Reading a diagnosis (``smeha diagnose --json``) into the extended model it names.

The extended model is a :class:`gmt.ModelVariant`; this is where the JSON of
the diagnosis is parsed (gmt reads only the variant itself).
"""
from __future__ import annotations

import json
import math
from collections.abc import Mapping

import gmt
from gmt import extensions as ext

__all__ = ["PAPER", "variant_from_diagnosis", "read_variant", "read_variant_json"]

PAPER = ext.PAPER


def variant_from_diagnosis(diagnosis: Mapping, cause: str | None = None,
                           form: str | None = None) -> gmt.ModelVariant:
    """The extended model of a diagnosis (``smeha diagnose --json`` or ``smeha paper``'s).

    Parameters
    ----------
    diagnosis : mapping
        With ``"cause"`` and ``"candidates"`` (each with ``"cause"``,
        ``"parameters"`` in SI and, for a cause with several formulations,
        ``"form"``), and since forward selection ``"model"``: the extended
        model itself (:meth:`gmt.ModelVariant.as_dict`, one extension or
        ``"components"``), which is taken when present.
    cause : str, optional
        Take this single candidate instead of the winner.
    form : str, optional
        With ``cause``: take this form of it (default: its best-scoring form).

    Without ``"model"``, the winner is the candidate of the diagnosis'
    ``"cause"`` *and* ``"form"`` (a candidate without ``"form"`` is its cause's
    first form); without a form to go by (a top-level ``"form"`` that is
    absent or "", or ``cause`` without ``form``) the cause's candidate with the
    lowest ``"score"`` (``smeha diagnose``) or held-out RMS (``smeha paper``).

    Returns
    -------
    gmt.ModelVariant
        The paper's model when the cause is ``"none"``.

    Raises
    ------
    gmt.ParameterError
        ``"unexplained"`` (no winner; name a candidate with ``cause``), an
        unknown form (the message names it and the cause's forms), or no
        candidate of that cause and form in the diagnosis.

    Examples
    --------
    >>> d = {"cause": "mechanical_resonance", "form": "two_dof", "candidates": [
    ...     {"cause": "mechanical_resonance", "form": "one_dof", "score": 9.0,
    ...      "parameters": {"mass_kg": 0.02, "damping_N_s_per_m": 2945.0,
    ...                     "stiffness_N_per_m": 1.963e7}},
    ...     {"cause": "mechanical_resonance", "form": "two_dof", "score": 5.0,
    ...      "parameters": {"rod_mass_kg": 0.01, "output_mass_kg": 0.01,
    ...                     "joint_stiffness_N_per_m": 4e8,
    ...                     "joint_damping_N_s_per_m": 400.0}}]}
    >>> variant_from_diagnosis(d).name
    'mechanical_resonance:two_dof'
    >>> variant_from_diagnosis(d, "mechanical_resonance", "one_dof").name
    'mechanical_resonance'
    """
    if not isinstance(diagnosis, Mapping) or "cause" not in diagnosis:
        raise gmt.ParameterError("diagnosis must be a mapping with 'cause' and 'candidates' "
                                 "(the output of smeha diagnose --json)")
    chosen = diagnosis["cause"] if cause is None else cause
    if chosen in ("none", PAPER):
        return gmt.ModelVariant()
    candidates = [c for c in diagnosis.get("candidates") or () if isinstance(c, Mapping)]
    if chosen == "unexplained":
        names = [c.get("cause") for c in candidates]
        raise gmt.ParameterError("the diagnosis names no extension (cause 'unexplained'); "
                                 f"choose one of its candidates {names} explicitly")
    model = diagnosis.get("model")
    if cause is None and isinstance(model, Mapping) and (
            "components" in model or model.get("cause") in ext.CAUSES):
        return gmt.ModelVariant.from_dict(model)
    forms = ext.forms_of(chosen)
    if not forms:
        raise gmt.ParameterError(f"cause = {chosen!r} is not one of {ext.CAUSES}")
    wanted = (diagnosis.get("form") if cause is None else form) or ""
    if wanted and wanted not in forms:
        raise gmt.ParameterError(f"form = {wanted!r} is not a form of {chosen!r}: the allowed "
                                 f"forms are {list(forms)}")
    best = _best_candidate(candidates, chosen, wanted, forms)
    return gmt.ModelVariant(chosen, dict(best.get("parameters") or {}), best.get("form") or "")


def _rank(candidate) -> float:
    """A candidate's ``"score"`` (smeha diagnose) or held-out RMS (smeha paper); inf without."""
    for key in ("score", "heldout_rms_um"):
        if isinstance(candidate.get(key), (int, float)):
            return float(candidate[key])
    return math.inf


def _best_candidate(candidates, chosen, wanted, forms) -> Mapping:
    """The best-ranked single candidate of cause ``chosen`` and, if ``wanted``, of that form
    (a candidate without ``"form"`` is of the cause's first, ``forms[0]``)."""
    matches = [c for c in candidates if c.get("cause") == chosen
               and len(c.get("causes") or [chosen]) == 1]
    if not matches:
        names = [c.get("cause") for c in candidates]
        why = ("" if names else "; a diagnosis whose answer is 'none' fits no candidate: "
               "the paper's model is within noise")
        raise gmt.ParameterError(f"cause = {chosen!r} has no candidate in the diagnosis "
                                 f"(candidates: {names}){why}")
    if wanted:
        present = [c.get("form") or forms[0] for c in matches]
        matches = [c for c, f in zip(matches, present) if f == wanted]
        if not matches:
            raise gmt.ParameterError(f"cause = {chosen!r} has no candidate of form "
                                     f"{wanted!r} in the diagnosis (its forms there: "
                                     f"{sorted(set(present))})")
    return min(matches, key=_rank)


def read_variant(data) -> gmt.ModelVariant:
    """The variant of a JSON object: a whole diagnosis or a small variant file.

    A diagnosis (it has ``"candidates"``) goes through
    :func:`variant_from_diagnosis`; anything else through
    :meth:`gmt.ModelVariant.from_dict` (``{"cause", "form", "parameters"}`` or
    ``{"components": [...]}``, such as ``data/paper_variant.json``).
    """
    if isinstance(data, Mapping) and "candidates" in data:
        return variant_from_diagnosis(data)
    return gmt.ModelVariant.from_dict(data)


def read_variant_json(text: str) -> gmt.ModelVariant:
    """:func:`read_variant` of a JSON text (gmt.ParameterError for invalid JSON)."""
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise gmt.ParameterError(f"not valid JSON ({exc})") from None
    return read_variant(data)
