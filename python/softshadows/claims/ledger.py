"""The ledger's machinery: papers, claims, verdict rules, the registry, and the runs.

A :class:`Claim` pairs one sentence of a paper (with the paper's own number and where it is
stated) with a function that measures the same quantity on this implementation and a
:class:`Rule` that turns our numbers into one of the four :data:`VERDICTS`. Claims register
themselves in :data:`CLAIMS` with the :func:`claim` decorator, one module per paper, and one for
the section beyond the papers (:data:`BEYOND`): questions their readers ask that none of them
answers, each stated as a hypothesis and measured the same way.
"""

from __future__ import annotations

import abc
import dataclasses
import datetime
import math
import os
import platform
import time
from pathlib import Path
from typing import Callable, Mapping

__all__ = [
    "VERDICTS", "PAPERS", "BEYOND", "SECTIONS", "CLAIMS", "Paper", "Beyond", "Tier", "Measured", "Tol", "Claim", "claim",
    "Rule", "AtMost", "AtLeast", "Between", "AllOf", "NotMeasurable",
    "reproduce", "write_report", "record_expected", "compare_expected", "machine", "update_readme",
]

#: The verdicts, best first. ``holds in kind``: the direction and rough size of the claim hold,
#: its absolute number belongs to another machine (a GPU, another scene size).
VERDICTS = ("holds", "holds in kind", "refuted", "not measurable here")


@dataclasses.dataclass(frozen=True)
class Paper:
    """A paper whose claims the ledger measures.

    Examples
    --------
    >>> from softshadows import claims
    >>> paper = claims.PAPERS["forest09"]
    >>> paper.short
    'Forest et al. 2009'
    >>> paper.cite()
    'Vincent Forest, Loïc Barthe, Gaël Guennebaud and Mathias Paulin. Soft Textured Shadow Volume. Eurographics Symposium on Rendering, 2009.'
    """

    key: str
    authors: str
    year: int
    title: str
    venue: str

    @property
    def short(self) -> str:
        """``First-author et al. year`` (or both names for two authors)."""
        names = [n.strip() for n in self.authors.replace(" and ", ", ").split(",") if n.strip()]
        last = lambda n: n.split()[-1]  # noqa: E731
        lead = f"{last(names[0])} and {last(names[1])}" if len(names) == 2 else f"{last(names[0])} et al."
        return f"{lead} {self.year}"

    def cite(self) -> str:
        return f"{self.authors}. {self.title}. {self.venue}, {self.year}."

    @property
    def heading(self) -> str:
        """The title of its section in the ledger."""
        return f"{self.short}: {self.title}"

    @property
    def label(self) -> str:
        """Its name in the README's one line per section (Markdown)."""
        return f"**{self.short}**, *{self.title}*"


#: The five papers, by the key that starts their claims' ids.
PAPERS = {
    p.key: p
    for p in (
        Paper("sintorn08", "Erik Sintorn, Elmar Eisemann and Ulf Assarsson", 2008,
              "Sample Based Visibility for Soft Shadows using Alias-free Shadow Maps", "Eurographics Symposium on Rendering"),
        Paper("forest09", "Vincent Forest, Loïc Barthe, Gaël Guennebaud and Mathias Paulin", 2009,
              "Soft Textured Shadow Volume", "Eurographics Symposium on Rendering"),
        Paper("annen08", "Thomas Annen, Zhao Dong, Tom Mertens, Philippe Bekaert, Hans-Peter Seidel and Jan Kautz", 2008,
              "Real-time, All-Frequency Shadows in Dynamic Scenes", "ACM SIGGRAPH"),
        Paper("schwarz08", "Michael Schwarz and Marc Stamminger", 2008,
              "Quality Scalability of Soft Shadow Mapping", "Graphics Interface"),
        Paper("marrs18", "Adam Marrs, Benjamin Watson and Christopher G. Healey", 2018,
              "View-warped Multi-view Soft Shadows for Local Area Lights", "Journal of Computer Graphics Techniques 7(3)"),
    )
}


@dataclasses.dataclass(frozen=True)
class Beyond:
    """A section of the ledger that is no paper's: questions the papers' readers ask that none of
    them answers (a baseline they predate, how their methods behave over time). Each of its
    claims states a hypothesis in the place of a paper's sentence, and is measured and judged
    the same way.

    Examples
    --------
    >>> from softshadows import claims
    >>> claims.BEYOND.heading, claims.SECTIONS["beyond"] is claims.BEYOND
    ('Beyond the papers', True)
    """

    key: str
    title: str
    #: What the section asks, printed under its heading (where a paper's section cites it).
    about: str

    @property
    def short(self) -> str:
        return self.title

    def cite(self) -> str:
        return self.about

    @property
    def heading(self) -> str:
        return self.title

    @property
    def label(self) -> str:
        return f"**{self.title}**"


#: The section beyond the five papers (``claims/beyond.py``).
BEYOND = Beyond(
    "beyond", "Beyond the papers",
    "Questions a reader of the five papers asks that none of them answers, each stated as a hypothesis and measured "
    "here as the papers' claims are: where today's baseline, a denoised ray tracer that postdates them, sits among "
    "their methods, still and over time.",
)

#: The ledger's sections by key, in the order of its report: the five papers, then :data:`BEYOND`.
SECTIONS = {**PAPERS, BEYOND.key: BEYOND}


@dataclasses.dataclass(frozen=True)
class Tier:
    """How big a run is: ``fast`` (small sizes, minutes for the whole ledger, run by the tests) or
    ``paper`` (the papers' own sizes, up to an hour). ``figures``: draw the claims' pictures.

    Examples
    --------
    >>> from softshadows import claims
    >>> claims.Tier("fast").pick(64, 512), claims.Tier("paper").pick(64, 512)
    (64, 512)
    """

    name: str = "fast"
    figures: bool = False

    def __post_init__(self):
        if self.name not in ("fast", "paper"):
            raise ValueError(f"tier: expected 'fast' or 'paper', got {self.name!r}")

    def pick(self, fast, paper):
        """``fast`` in the fast tier, ``paper`` in the paper tier."""
        return fast if self.name == "fast" else paper


@dataclasses.dataclass
class Measured:
    """What a claim's measurement returns: named numbers (the rule reads them, the ledger prints
    them), optionally a matplotlib figure, and a note on the set-up.

    Examples
    --------
    >>> from softshadows import claims
    >>> measured = claims.Measured({"speedup": 2.4}, note="columns, 256² receivers")
    >>> measured.values["speedup"], measured.figure is None
    (2.4, True)
    """

    values: dict
    figure: object = None
    note: str = ""


@dataclasses.dataclass(frozen=True)
class Tol:
    """How far a re-measured value may drift from its recorded one: within ``rtol * |recorded| +
    atol``; or, for a value read off the machine's clock (``clocked``), any distance.

    A clocked value (a ratio of seconds measured side by side, a slope or a fit of times, absolute
    seconds) is judged by the ledger's rules and printed, but a re-measurement never fails on it:
    speed is the benchmarks' to measure, and on a shared machine one fast-tier ratio moved ninefold
    between two runs of the same code (0.34 recorded, 0.039 on a fresh CI machine).

    Examples
    --------
    >>> from softshadows import claims
    >>> claims.Tol(rtol=0.02).accepts(1.01, 1.0), claims.Tol(rtol=0.02).accepts(1.05, 1.0)
    (True, False)
    >>> claims.TIMING.accepts(9.0, 1.0), claims.WALL_CLOCK.accepts(300.0, 1.0)
    (True, True)
    """

    rtol: float = 0.0
    atol: float = 0.0
    #: The value comes from the machine's clock: any re-measured value is accepted.
    clocked: bool = False
    #: Absolute seconds (:data:`WALL_CLOCK`), which no rule may read.
    absolute: bool = False

    def accepts(self, value: float, recorded: float) -> bool:
        if self.clocked:
            return True
        if math.isnan(value) or math.isnan(recorded):
            return math.isnan(value) and math.isnan(recorded)
        return abs(value - recorded) <= self.rtol * abs(recorded) + self.atol


#: Deterministic quantities (errors, counts, memory) re-measure to the same bits on one machine;
#: this leaves room for another BLAS or libm.
DETERMINISTIC = Tol(rtol=0.02, atol=1e-4)
#: Ratios of seconds measured side by side, and the slopes, fits and savings made of them: the
#: ledger's verdicts read them, the fast tier's test does not compare them.
TIMING = Tol(clocked=True)
#: Absolute seconds: they say how fast the recording machine was, not whether a claim holds (a
#: fresh CI machine built the YSM in 10.7 ms where the recording one took 27.9), so no rule reads
#: them.
WALL_CLOCK = Tol(clocked=True, absolute=True)


class Rule(abc.ABC):
    """Turns a claim's measured values into a verdict; :meth:`describe` says how, for the ledger.

    Examples
    --------
    >>> from softshadows import claims
    >>> rule = claims.AtMost("rmse", 0.02, in_kind=0.05)
    >>> isinstance(rule, claims.Rule), rule.describe()
    (True, 'holds if rmse ≤ 0.02, in kind if ≤ 0.05')
    """

    @abc.abstractmethod
    def verdict(self, values: Mapping[str, float]) -> str:
        """One of :data:`VERDICTS`."""

    @abc.abstractmethod
    def describe(self) -> str:
        """The rule in words."""


def _value(values, key):
    if key not in values:
        raise KeyError(f"the rule reads {key!r}, which the measurement did not return (it returned {sorted(values)})")
    return float(values[key])


@dataclasses.dataclass(frozen=True)
class _Threshold(Rule):
    """``holds`` when ``values[key]`` is on the good side of ``holds``; ``holds in kind`` when it
    is on the good side of ``in_kind``; else ``refuted``. Subclasses say which side is good."""

    key: str
    holds: float
    in_kind: float | None = None
    #: The comparison that passes, and its symbol for the ledger.
    passes = staticmethod(lambda x, limit: True)
    symbol = ""

    def verdict(self, values):
        x = _value(values, self.key)
        if self.passes(x, self.holds):
            return "holds"
        return "holds in kind" if self.in_kind is not None and self.passes(x, self.in_kind) else "refuted"

    def describe(self):
        kind = f", in kind if {self.symbol} {self.in_kind:g}" if self.in_kind is not None else ""
        return f"holds if {self.key} {self.symbol} {self.holds:g}{kind}"


@dataclasses.dataclass(frozen=True)
class AtMost(_Threshold):
    """``holds`` when ``values[key] <= holds``; ``holds in kind`` when ``<= in_kind``; else
    ``refuted``.

    Examples
    --------
    >>> from softshadows import claims
    >>> rule = claims.AtMost("rmse", 0.02, in_kind=0.05)
    >>> [rule.verdict({"rmse": x}) for x in (0.01, 0.03, 0.1)]
    ['holds', 'holds in kind', 'refuted']
    """

    passes = staticmethod(lambda x, limit: x <= limit)
    symbol = "≤"


@dataclasses.dataclass(frozen=True)
class AtLeast(_Threshold):
    """``holds`` when ``values[key] >= holds``; ``holds in kind`` when ``>= in_kind``; else
    ``refuted``.

    Examples
    --------
    >>> from softshadows import claims
    >>> rule = claims.AtLeast("speedup", 2.0, in_kind=1.2)
    >>> [rule.verdict({"speedup": x}) for x in (3.0, 1.5, 0.9)]
    ['holds', 'holds in kind', 'refuted']
    """

    passes = staticmethod(lambda x, limit: x >= limit)
    symbol = "≥"


@dataclasses.dataclass(frozen=True)
class Between(Rule):
    """``holds`` when ``low <= values[key] <= high``; ``holds in kind`` inside ``in_kind`` (a
    wider ``(low, high)``); else ``refuted``.

    Examples
    --------
    >>> from softshadows import claims
    >>> rule = claims.Between("ratio", 2.0, 5.0, in_kind=(1.2, float("inf")))
    >>> [rule.verdict({"ratio": x}) for x in (3.0, 20.0, 1.0)]
    ['holds', 'holds in kind', 'refuted']
    """

    key: str
    low: float
    high: float
    in_kind: tuple | None = None

    def verdict(self, values):
        x = _value(values, self.key)
        if self.low <= x <= self.high:
            return "holds"
        if self.in_kind is not None and self.in_kind[0] <= x <= self.in_kind[1]:
            return "holds in kind"
        return "refuted"

    def describe(self):
        kind = f", in kind if in [{self.in_kind[0]:g}, {self.in_kind[1]:g}]" if self.in_kind is not None else ""
        return f"holds if {self.key} in [{self.low:g}, {self.high:g}]{kind}"


@dataclasses.dataclass(frozen=True)
class AllOf(Rule):
    """The worst verdict of several rules (``refuted`` < ``holds in kind`` < ``holds``).

    Examples
    --------
    >>> from softshadows import claims
    >>> rule = claims.AllOf(claims.AtLeast("speedup", 2.0), claims.AtMost("rmse", 0.02, in_kind=0.05))
    >>> rule.verdict({"speedup": 3.0, "rmse": 0.03})  # the worse of the two
    'holds in kind'
    """

    rules: tuple

    def __init__(self, *rules: Rule):
        object.__setattr__(self, "rules", tuple(rules))

    def verdict(self, values):
        order = ("refuted", "holds in kind", "holds")
        return min((r.verdict(values) for r in self.rules), key=order.index)

    def describe(self):
        return "; ".join(r.describe() for r in self.rules)


@dataclasses.dataclass(frozen=True)
class NotMeasurable(Rule):
    """``not measurable here``, for the ``reason`` given; the measurement still reports what can
    be measured (ratios, work counters).

    Examples
    --------
    >>> from softshadows import claims
    >>> rule = claims.NotMeasurable("it times a GPU's memory bandwidth")
    >>> rule.verdict({"ratio": 1.0})
    'not measurable here'
    """

    reason: str

    def verdict(self, values):
        return "not measurable here"

    def describe(self):
        return f"not measurable here: {self.reason}"


@dataclasses.dataclass(frozen=True)
class Claim:
    """One claim of a paper (or one hypothesis beyond the papers, its ``paper`` the section
:data:`BEYOND`) and how this implementation measures it.

    ``ours`` formats the measured values for the ledger (``str.format`` over them, e.g.
    ``"{ratio:.2f}x"``); ``tolerance`` maps a value's name to the :class:`Tol` within which a
    re-measurement must agree with the recorded one (unnamed values: :data:`DETERMINISTIC`).

    Examples
    --------
    >>> from softshadows import claims
    >>> c = claims.CLAIMS["marrs18.occluder_fusion"]
    >>> c.paper.short, c.where
    ('Marrs et al. 2018', 'Section 2.1, Figure 10 (bottom)')
    >>> c.tol("rmse_pcss") is claims.DETERMINISTIC  # no tolerance of its own
    True
    """

    id: str
    paper: Paper | Beyond
    where: str
    statement: str
    paper_value: str
    measure: Callable[[Tier], Measured]
    rule: Rule
    ours: str
    tolerance: Mapping[str, Tol] = dataclasses.field(default_factory=dict)

    def tol(self, key: str) -> Tol:
        return self.tolerance.get(key, DETERMINISTIC)


#: Every registered claim by id, in registration order (section by section).
CLAIMS: dict[str, Claim] = {}


def claim(id: str, *, where: str, statement: str, paper_value: str, rule: Rule, ours: str, tolerance=None):
    """Registers the decorated function ``f(tier) -> Measured`` as the measurement of a claim.

    ``id`` is ``"<section key>.<name>"``, the section key one of :data:`SECTIONS` (a paper's, or
    ``beyond``).

    Examples
    --------
    >>> from softshadows import claims
    >>> @claims.claim("marrs18.example", where="Section 1", statement="Two is more than one.",
    ...               paper_value="2 > 1", rule=claims.AtLeast("ratio", 1.5), ours="{ratio:.1f}x")
    ... def _example(tier):
    ...     return claims.Measured({"ratio": 2.0})
    >>> claims.CLAIMS["marrs18.example"].measure(claims.Tier()).values
    {'ratio': 2.0}
    >>> del claims.CLAIMS["marrs18.example"]
    """
    key = id.split(".", 1)[0]
    if key not in SECTIONS or "." not in id:
        raise ValueError(f"id: expected '<section>.<name>' with <section> in {list(SECTIONS)}, got {id!r}")
    if id in CLAIMS:
        raise ValueError(f"id: {id!r} is registered twice")

    def register(measure):
        CLAIMS[id] = Claim(id, SECTIONS[key], where, statement, paper_value, measure, rule, ours, dict(tolerance or {}))
        return measure

    return register


def _selected(papers, ids):
    if papers is not None:
        if isinstance(papers, str):
            papers = [p.strip() for p in papers.split(",") if p.strip()]
        unknown = [p for p in papers if p not in SECTIONS]
        if unknown:
            raise ValueError(f"papers: unknown {unknown}; expected keys from {list(SECTIONS)}")
    if ids is not None:
        unknown = [i for i in ids if i not in CLAIMS]
        if unknown:
            raise ValueError(f"ids: unknown {unknown}; see softshadows.claims.CLAIMS")
    return [c for c in CLAIMS.values() if (papers is None or c.paper.key in papers) and (ids is None or c.id in ids)]


def _format(template: str, values: Mapping) -> str:
    try:
        return template.format(**values)
    except (KeyError, ValueError, IndexError) as err:
        return f"{values} (format {template!r}: {err})"


def reproduce(papers=None, *, tier: str = "fast", out=None, ids=None, figures: bool | None = None, progress: bool = True):
    """Measures the claims of the ledger on this implementation.

    Parameters
    ----------
    papers : sequence of str or str, optional
        Section keys from :data:`SECTIONS` (a paper's, ``"sintorn08"``, ..., or ``"beyond"``)
        or a comma-separated string; default all.
    tier : {"fast", "paper"}
        ``fast``: small sizes, the whole ledger in minutes; ``paper``: the papers' own sizes.
    out : path-like, optional
        Also write ``claims.md``, ``claims.csv`` and the figures (``claims/<id>.png``) there.
    ids : sequence of str, optional
        Only these claim ids.
    figures : bool, optional
        Draw the claims' figures; default: when ``out`` is given.
    progress : bool
        Show a progress bar (on a terminal).

    Returns
    -------
    pandas.DataFrame
        One row per claim: ``id``, ``paper``, ``where``, ``claim``, ``paper_value``, ``ours``,
        ``verdict`` (one of :data:`VERDICTS`, or ``error`` with the exception in ``note``),
        ``rule``, ``values`` (dict), ``note``, ``seconds``; the figures (PNG bytes by claim id) in ``frame.attrs["figures"]``
        and the run's tier, date and machine in ``frame.attrs["run"]``.

    Examples
    --------
    >>> from softshadows import claims
    >>> @claims.claim("marrs18.example", where="Section 1", statement="Two is more than one.",
    ...               paper_value="2 > 1", rule=claims.AtLeast("ratio", 1.5), ours="{ratio:.1f}x")
    ... def _example(tier):
    ...     return claims.Measured({"ratio": 2.0})
    >>> frame = claims.reproduce(ids=["marrs18.example"], progress=False)
    >>> frame[["id", "ours", "verdict"]].values.tolist()
    [['marrs18.example', '2.0x', 'holds']]
    >>> del claims.CLAIMS["marrs18.example"]
    """
    import pandas as pd
    from tqdm.auto import tqdm

    chosen = _selected(papers, ids)
    t = Tier(tier, figures=out is not None if figures is None else bool(figures))
    rows, figs = [], {}
    bar = tqdm(chosen, desc="claims", unit="claim", disable=None if progress else True)
    for c in bar:
        bar.set_description(c.id)
        start = time.perf_counter()
        try:
            m = c.measure(t)
            values = {k: float(v) for k, v in m.values.items()}
            verdict, note = c.rule.verdict(values), m.note
            if m.figure is not None:
                figs[c.id] = _png(m.figure)
        except Exception as err:  # a broken measurement is reported in its row, not lost with the run
            values, verdict, note = {}, "error", f"{type(err).__name__}: {err}"
        rows.append({
            "id": c.id, "paper": c.paper.key, "where": c.where, "claim": c.statement, "paper_value": c.paper_value,
            "ours": _format(c.ours, values) if values else "-", "verdict": verdict, "rule": c.rule.describe(),
            "values": values, "note": note, "seconds": time.perf_counter() - start,
        })
    frame = pd.DataFrame(rows, columns=["id", "paper", "where", "claim", "paper_value", "ours", "verdict", "rule",
                                        "values", "note", "seconds"])
    frame.attrs["figures"] = figs
    frame.attrs["run"] = {"tier": t.name, "date": datetime.date.today().isoformat(), "machine": machine()}
    if out is not None:
        write_report(frame, out)
    return frame


def _png(figure) -> bytes:
    """A figure as PNG bytes: ``frame.attrs`` is deep-copied by every pandas operation, which
    costs seconds per matplotlib figure and nothing per bytes object."""
    import io

    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110, bbox_inches="tight")
    return buffer.getvalue()


def machine() -> str:
    """The machine a run was measured on, in one line.

    Examples
    --------
    >>> from softshadows import claims
    >>> "CPU threads" in claims.machine() and "Python" in claims.machine()
    True
    """
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    try:
        memory = f", {os.sysconf('SC_PAGE_SIZE') * os.sysconf('SC_PHYS_PAGES') / 2**30:.0f} GiB"
    except (ValueError, OSError, AttributeError):
        memory = ""
    return f"{cpu}, {os.cpu_count()} CPU threads{memory}, {platform.system()} {platform.release()}, Python {platform.python_version()}"


def _cell(text) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def verdict_counts(frame) -> str:
    """``3 hold, 1 holds in kind, ...`` for a set of rows."""
    words = {"holds": ("holds", "hold"), "holds in kind": ("holds in kind", "hold in kind"), "refuted": ("refuted", "refuted"),
             "not measurable here": ("not measurable here", "not measurable here"), "error": ("error", "errors")}
    counts = frame["verdict"].value_counts()
    parts = [f"{counts[v]} {words[v][int(counts[v] != 1)]}" for v in words if v in counts]
    return ", ".join(parts)


def write_report(frame, out) -> Path:
    """Writes ``claims.md`` (one table per section, figures below it), ``claims.csv`` and the
    figures (``claims/<id>.png``) into the folder ``out``; returns the Markdown file's path.

    Examples
    --------
    >>> import os, tempfile
    >>> from softshadows import claims
    >>> @claims.claim("marrs18.example", where="Section 1", statement="Two is more than one.",
    ...               paper_value="2 > 1", rule=claims.AtLeast("ratio", 1.5), ours="{ratio:.1f}x")
    ... def _example(tier):
    ...     return claims.Measured({"ratio": 2.0})
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = claims.write_report(claims.reproduce(ids=["marrs18.example"], progress=False), folder.name)
    >>> path.name, sorted(os.listdir(folder.name))
    ('claims.md', ['claims.csv', 'claims.md'])
    >>> "Two is more than one." in path.read_text()
    True
    >>> del claims.CLAIMS["marrs18.example"]
    """
    import json

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    figs = frame.attrs.get("figures", {})
    if figs:
        (out / "claims").mkdir(exist_ok=True)
    for cid, png in figs.items():
        (out / "claims" / f"{cid}.png").write_bytes(png)
    run = frame.attrs.get("run", {})
    lines = [
        "# The claims ledger",
        "",
        f"Every headline claim of the five papers, and beyond them the questions none of them answers, measured on "
        f"this implementation by `softshadows reproduce --tier {run.get('tier', '?')}` on {run.get('date', '?')}, on "
        f"{run.get('machine', '?')}.",
        "",
        "Verdicts: **holds** (our number meets the paper's); **holds in kind** (the direction and rough size hold, "
        "the absolute number is another machine's or another scene's); **refuted** (with our numbers); "
        "**not measurable here** (with the reason, and what could be measured). Times are CPU seconds on the machine "
        "above, where the papers timed GPUs: a ratio measured side by side in one run is what carries over.",
        "",
    ]
    for key, section in SECTIONS.items():
        rows = frame[frame["paper"] == key]
        if rows.empty:
            continue
        lines += [f"## {section.heading}", "", f"{section.cite()}", "", f"**{verdict_counts(rows)}.**", "",
                  "| claim | where | the paper | ours | verdict |", "|---|---|---|---|---|"]
        for _, r in rows.iterrows():
            lines.append(f"| {_cell(r['claim'])} (`{r['id']}`) | {_cell(r['where'])} | {_cell(r['paper_value'])} | "
                         f"{_cell(r['ours'])} | **{r['verdict']}** |")
        notes = [(r["id"], r["note"], r["rule"]) for _, r in rows.iterrows()]
        lines += ["", "<details><summary>How each verdict is decided</summary>", ""]
        lines += [f"- `{cid}`: {rule}." + (f" {note}" if note else "") for cid, note, rule in notes]
        lines += ["", "</details>", ""]
        for cid in rows["id"]:
            if cid in figs:
                lines += [f"![{cid}](claims/{cid}.png)", "", f"*`{cid}`*", ""]
    path = out / "claims.md"
    path.write_text("\n".join(lines))
    flat = frame.drop(columns=["values"]).assign(values=[json.dumps(v, sort_keys=True) for v in frame["values"]])
    flat.to_csv(out / "claims.csv", index=False)
    return path


#: The README block that quotes one verdict line per paper.
README_MARKERS = ("<!-- claims:start -->", "<!-- claims:end -->")


def update_readme(frame, path) -> None:
    """Replaces the block between :data:`README_MARKERS` in the file ``path`` with one line per
    section (each paper, then beyond the papers): its verdict counts.

    Examples
    --------
    >>> import os, tempfile
    >>> from softshadows import claims
    >>> @claims.claim("marrs18.example", where="Section 1", statement="Two is more than one.",
    ...               paper_value="2 > 1", rule=claims.AtLeast("ratio", 1.5), ours="{ratio:.1f}x")
    ... def _example(tier):
    ...     return claims.Measured({"ratio": 2.0})
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = os.path.join(folder.name, "README.md")
    >>> start, end = claims.ledger.README_MARKERS
    >>> with open(path, "w") as f:
    ...     _ = f.write(os.linesep.join(["# Claims", start, end, ""]))
    >>> claims.update_readme(claims.reproduce(ids=["marrs18.example"], progress=False), path)
    >>> open(path).read().splitlines()[2]
    '- **Marrs et al. 2018**, *View-warped Multi-view Soft Shadows for Local Area Lights*: 1 holds.'
    >>> del claims.CLAIMS["marrs18.example"]
    """
    path = Path(path)
    text = path.read_text()
    start, end = README_MARKERS
    if start not in text or end not in text:
        raise ValueError(f"path: {path} has no {start} ... {end} block to fill")
    run = frame.attrs.get("run", {})
    lines = []
    for key, section in SECTIONS.items():
        rows = frame[frame["paper"] == key]
        if not rows.empty:
            lines.append(f"- {section.label}: {verdict_counts(rows)}.")
    note = f"*`softshadows reproduce --tier {run.get('tier', '?')}`, {run.get('date', '?')}; every row in [docs/claims.md](docs/claims.md).*"
    block = "\n".join([start, *lines, "", note, end])
    head, rest = text.split(start, 1)
    path.write_text(head + block + rest.split(end, 1)[1])


def record_expected(frame, path) -> Path:
    """Writes every measured value and verdict of a fast-tier run to the CSV ``path`` (the
    expectations ``tests/claims`` re-measures against), with a dated header naming the command.

    Examples
    --------
    >>> import os, tempfile
    >>> from softshadows import claims
    >>> @claims.claim("marrs18.example", where="Section 1", statement="Two is more than one.",
    ...               paper_value="2 > 1", rule=claims.AtLeast("ratio", 1.5), ours="{ratio:.1f}x")
    ... def _example(tier):
    ...     return claims.Measured({"ratio": 2.0})
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = claims.record_expected(claims.reproduce(ids=["marrs18.example"], progress=False),
    ...                               os.path.join(folder.name, "expected.csv"))
    >>> path.read_text().splitlines()[-1]
    'marrs18.example,ratio,2.0,holds'
    >>> del claims.CLAIMS["marrs18.example"]
    """
    import csv

    run = frame.attrs.get("run", {})
    if run.get("tier") != "fast":
        raise ValueError("frame: only a fast-tier run is recorded as the tests' expectations")
    bad = frame[~frame["verdict"].isin(VERDICTS)]
    if not bad.empty:
        raise ValueError(f"frame: these claims have no verdict, fix them before recording: {list(bad['id'])}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        f.write(f"# written by `softshadows reproduce --tier fast --record {path}` on {run.get('date')}, "
                f"on {run.get('machine')}; never edited by hand\n")
        w = csv.writer(f)
        w.writerow(["id", "key", "value", "verdict"])
        for _, r in frame.iterrows():
            for key, value in sorted(r["values"].items()):
                w.writerow([r["id"], key, repr(float(value)), r["verdict"]])
    return path


def _rule_keys(rule) -> list:
    """The values that ``rule`` reads."""
    if isinstance(rule, AllOf):
        return [k for r in rule.rules for k in _rule_keys(r)]
    return [rule.key] if isinstance(rule, (_Threshold, Between)) else []


def _timing_noise(claim, values, recorded) -> bool:
    """Whether a changed verdict is the machine's load: the rule reads a clocked value, and every
    value it reads lies within its tolerance of the recorded one (the deterministic ones within
    theirs: unchanged), so only a timing moved it."""
    keys = _rule_keys(claim.rule)
    return any(claim.tol(key).clocked for key in keys) and all(
        key in values and key in recorded and claim.tol(key).accepts(float(values[key]), float(recorded[key]))
        for key in keys
    )


def compare_expected(frame, path) -> list:
    """The differences between a fast-tier run and the recorded expectations at ``path``: one
    message per changed verdict (but for a verdict that only timings moved, :func:`_timing_noise`), drifted value, or claim missing from either side.

    Examples
    --------
    >>> import os, tempfile
    >>> from softshadows import claims
    >>> ratio = 2.0
    >>> @claims.claim("marrs18.example", where="Section 1", statement="Two is more than one.",
    ...               paper_value="2 > 1", rule=claims.AtLeast("ratio", 1.5), ours="{ratio:.1f}x")
    ... def _example(tier):
    ...     return claims.Measured({"ratio": ratio})
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = os.path.join(folder.name, "expected.csv")
    >>> _ = claims.record_expected(claims.reproduce(ids=["marrs18.example"], progress=False), path)
    >>> claims.compare_expected(claims.reproduce(ids=["marrs18.example"], progress=False), path)
    []
    >>> ratio = 1.0
    >>> claims.compare_expected(claims.reproduce(ids=["marrs18.example"], progress=False), path)[0][:60]
    "marrs18.example: verdict 'refuted' (measured {'ratio': 1.0},"
    >>> del claims.CLAIMS["marrs18.example"]
    """
    import pandas as pd

    recorded = pd.read_csv(path, comment="#")
    problems = []
    measured = {r["id"]: r for _, r in frame.iterrows()}
    for cid, rows in recorded.groupby("id", sort=False):
        if cid not in measured:
            problems.append(f"{cid}: recorded but not measured (removed from the ledger? record again)")
            continue
        r = measured[cid]
        c = CLAIMS[cid]
        expected_verdict = rows["verdict"].iloc[0]
        recorded_values = dict(zip(rows["key"], rows["value"]))
        if r["verdict"] != expected_verdict and not _timing_noise(c, r["values"], recorded_values):
            problems.append(f"{cid}: verdict {r['verdict']!r} (measured {r['values']}, {r['note']}) but recorded "
                            f"{expected_verdict!r} (values {recorded_values})")
        for key, value in zip(rows["key"], rows["value"]):
            if key not in r["values"]:
                problems.append(f"{cid}: value {key!r} recorded ({value}) but no longer measured")
            elif not c.tol(key).accepts(r["values"][key], float(value)):
                problems.append(f"{cid}: {key} = {r['values'][key]!r}, recorded {value!r} (tolerance {c.tol(key)})")
    for cid in measured:
        if cid not in set(recorded["id"]):
            problems.append(f"{cid}: measured but never recorded (run `softshadows reproduce --tier fast --record ...`)")
    return problems
