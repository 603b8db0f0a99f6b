"""The study report's headline texts: its title, the count of the claims' verdicts, the run count, and each
verdict's colour class (the HTML report, berryshaker.report.html, and its tests use them)."""

from __future__ import annotations

#: the claims' verdicts in the order the headline counts them (berryshaker.study.claims)
VERDICTS = ("reproduced", "partly reproduced", "not reproduced", "undecided", "not tested", "not comparable")


def report_title(claims: list) -> str:
    """Title of the study report: "reproduced" only when every claim is; otherwise "checked".

    Parameters
    ----------
    claims : list of ClaimVerdict
        The claims with their ``verdict`` (``berryshaker.study.claims.ClaimVerdict``, read by attribute).

    Returns
    -------
    str
        The title.
    """
    verdicts = [c.verdict for c in claims]
    if verdicts and all(v == "reproduced" for v in verdicts):
        return "Blueberry harvester with transmission clearance: the reference study, reproduced"
    return "Blueberry harvester with transmission clearance: the reference study, checked"


def verdict_counts(claims: list) -> str:
    """E.g. "5 of 8 claims reproduced, 2 partly reproduced, 1 not reproduced".

    Parameters
    ----------
    claims : list of ClaimVerdict
        The claims with their ``verdict`` (read by attribute).

    Returns
    -------
    str
        The counts in words.
    """
    order = VERDICTS
    counts = {v: sum(1 for c in claims if c.verdict == v) for v in order}
    others = sum(1 for c in claims if c.verdict not in order)
    parts = [f"{counts[order[0]]} of {len(claims)} claims reproduced"]
    parts += [f"{counts[v]} {v}" for v in order[1:] if counts[v]]
    if others:
        parts.append(f"{others} other")
    return ", ".join(parts)


def runs_text(runs: dict) -> str:
    """The run count for the report header: "N runs (M from the cache; cold compute X s)".  The cold cost
    (:class:`berryshaker.runs.runner.SweepRunner` ``stats["cold_compute_s"]``: compute seconds now plus the
    stored seconds of the cached runs) stays the same after a cached rerun.

    Parameters
    ----------
    runs : dict
        The runner's statistics (runs, cached, compute_s, cold_compute_s, failed).

    Returns
    -------
    str
        The text.
    """
    n = runs.get("runs", 0)
    cached = runs.get("cached", 0)
    cold = runs.get("cold_compute_s")
    if cold is None and "compute_s" in runs:
        cold = runs["compute_s"] + runs.get("cached_compute_s", 0.0)
    text = f"{n} runs ({cached} from the cache"
    if cold is not None:
        text += f"; cold compute {cold:.1f} s"
    if runs.get("failed"):
        text += f"; {runs['failed']} failed"
    return text + ")"


def verdict_class(verdict: str) -> str:
    """CSS class of a claim's verdict in the report (its colour): "undecided" as "partly"; "not tested" (a claim
    that holds by construction of the model) as "not comparable".

    Parameters
    ----------
    verdict : str
        A claim's verdict.

    Returns
    -------
    str
        The CSS class.
    """
    return {"reproduced": "v-reproduced", "not reproduced": "v-not", "partly reproduced": "v-partly",
            "undecided": "v-partly"}.get(verdict, "v-nc")
