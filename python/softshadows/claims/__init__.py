"""The claims ledger: every headline claim of the five papers, measured on this implementation.

Each claim names its paper (authors, year, title), where the paper states it (a section, figure
or table), the claim in one sentence with the paper's own number, a measurement of the same
quantity here, and a rule that gives one of four verdicts: ``holds``, ``holds in kind`` (the
direction and rough size hold; the absolute number is another machine's), ``refuted`` (with our
numbers) or ``not measurable here`` (with the reason; what can be measured still is). A last
section, beyond the papers (``beyond``, :data:`BEYOND`), asks what none of them answers: where
today's baseline, a denoised ray tracer, sits among their methods, still and over time; each of
its claims is a hypothesis, measured and judged the same way.

:func:`reproduce` runs them (``softshadows reproduce`` on the command line) and returns a pandas
DataFrame; with ``out=`` it writes ``claims.md``, ``claims.csv`` and the figures. The ``fast``
tier runs at small sizes in minutes and is re-measured by the test suite against recorded
values (``tests/claims/expected.csv``); the ``paper`` tier runs at the papers' own sizes and
writes the repository's ``docs/claims.md``.

Examples
--------
>>> from softshadows import claims
>>> sorted(claims.PAPERS)
['annen08', 'forest09', 'marrs18', 'schwarz08', 'sintorn08']
>>> list(claims.SECTIONS)[-1]
'beyond'
>>> claims.AtMost("ratio", 2.0, in_kind=8.0).verdict({"ratio": 3.1})
'holds in kind'

References
----------
.. [1] E. Sintorn, E. Eisemann and U. Assarsson, "Sample Based Visibility for Soft Shadows using
   Alias-free Shadow Maps", Eurographics Symposium on Rendering, 2008.
.. [2] V. Forest, L. Barthe, G. Guennebaud and M. Paulin, "Soft Textured Shadow Volume",
   Eurographics Symposium on Rendering, 2009.
.. [3] T. Annen, Z. Dong, T. Mertens, P. Bekaert, H.-P. Seidel and J. Kautz, "Real-time,
   All-Frequency Shadows in Dynamic Scenes", ACM SIGGRAPH, 2008.
.. [4] M. Schwarz and M. Stamminger, "Quality Scalability of Soft Shadow Mapping", Graphics
   Interface, 2008.
.. [5] A. Marrs, B. Watson and C. G. Healey, "View-warped Multi-view Soft Shadows for Local Area
   Lights", Journal of Computer Graphics Techniques 7(3), 2018.
"""

from .ledger import (
    BEYOND, CLAIMS, DETERMINISTIC, PAPERS, SECTIONS, TIMING, VERDICTS, WALL_CLOCK, AllOf, AtLeast, AtMost, Between, Beyond,
    Claim, Measured, NotMeasurable, Paper, Rule, Tier, Tol, claim, compare_expected, machine, record_expected, reproduce,
    update_readme, write_report,
)

# The claims register themselves on import, paper by paper.
from . import annen08, forest09, marrs18, schwarz08, sintorn08  # noqa: E402,F401
from . import beyond  # noqa: E402,F401  (last: the section beyond the papers)

__all__ = [
    "BEYOND", "CLAIMS", "DETERMINISTIC", "PAPERS", "SECTIONS", "TIMING", "VERDICTS", "WALL_CLOCK", "AllOf", "AtLeast", "AtMost",
    "Between", "Beyond", "Claim",
    "Measured", "NotMeasurable", "Paper", "Rule", "Tier", "Tol", "claim", "compare_expected", "machine",
    "record_expected", "reproduce", "update_readme", "write_report",
]
