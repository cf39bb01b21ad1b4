"""The claims ledger: the verdict rules on inputs whose verdict is known, the registry's
well-formedness, and the fast tier re-measured against its recorded values.

``expected.csv`` beside this file is written by ``softshadows reproduce --tier fast --record
tests/claims/expected.csv`` (never by hand); a claim whose verdict changes, or whose value drifts
beyond its tolerance, fails with both numbers printed.
"""

import math
from functools import lru_cache
from pathlib import Path

import pandas as pd
import pytest

import softshadows as ss
from softshadows import claims
from softshadows.claims import ledger

EXPECTED = Path(__file__).with_name("expected.csv")


# --- verdict rules on synthetic inputs -------------------------------------------------------

@pytest.mark.parametrize("x, verdict", [(1.0, "holds"), (2.0, "holds"), (5.0, "holds in kind"), (8.0, "holds in kind"), (8.1, "refuted")])
def test_at_most_gives_the_known_verdicts(x, verdict):
    assert claims.AtMost("ratio", 2.0, in_kind=8.0).verdict({"ratio": x}) == verdict


@pytest.mark.parametrize("x, verdict", [(10.0, "holds"), (3.0, "holds in kind"), (0.5, "refuted")])
def test_at_least_gives_the_known_verdicts(x, verdict):
    assert claims.AtLeast("speedup", 10.0, in_kind=2.0).verdict({"speedup": x}) == verdict


def test_a_rule_without_an_in_kind_band_only_holds_or_is_refuted():
    rule = claims.AtMost("rmse", 0.01)
    assert rule.verdict({"rmse": 0.005}) == "holds"
    assert rule.verdict({"rmse": 0.02}) == "refuted"


@pytest.mark.parametrize("x, verdict", [(1.0, "holds"), (0.8, "holds"), (0.6, "holds in kind"), (2.5, "refuted"), (0.1, "refuted")])
def test_between_gives_the_known_verdicts(x, verdict):
    assert claims.Between("cost", 0.8, 1.25, in_kind=(0.5, 2.0)).verdict({"cost": x}) == verdict


def test_all_of_gives_the_worst_verdict():
    rule = claims.AllOf(claims.AtMost("a", 1.0, in_kind=2.0), claims.AtLeast("b", 1.0))
    assert rule.verdict({"a": 0.5, "b": 2.0}) == "holds"
    assert rule.verdict({"a": 1.5, "b": 2.0}) == "holds in kind"
    assert rule.verdict({"a": 1.5, "b": 0.0}) == "refuted"


def test_not_measurable_ignores_the_numbers_and_says_why():
    rule = claims.NotMeasurable("a GPU frame rate on a CPU-only machine")
    assert rule.verdict({"ratio": 1e9}) == "not measurable here"
    assert "GPU" in rule.describe()


def test_a_rule_reading_a_value_the_measurement_lacks_names_it():
    with pytest.raises(KeyError, match="ratio"):
        claims.AtMost("ratio", 1.0).verdict({"other": 1.0})


def test_deterministic_values_must_re_measure_and_clocked_ones_never_fail():
    assert claims.DETERMINISTIC.accepts(1.01, 1.0) and not claims.DETERMINISTIC.accepts(1.05, 1.0)
    assert not claims.DETERMINISTIC.accepts(math.nan, 1.0) and claims.DETERMINISTIC.accepts(math.nan, math.nan)
    # The ratio that moved ninefold between two runs of one commit, and a wall time of another machine.
    assert claims.TIMING.accepts(0.039, 0.34) and claims.TIMING.accepts(3.0, 1.0)
    assert claims.WALL_CLOCK.accepts(10.7, 27.9) and claims.WALL_CLOCK.accepts(300.0, 27.9)


def test_a_broken_measurement_is_reported_in_its_row(monkeypatch):
    def broken(tier):
        raise RuntimeError("boom")

    monkeypatch.setitem(claims.CLAIMS, "annen08.broken", claims.Claim(
        "annen08.broken", claims.PAPERS["annen08"], "nowhere", "a claim", "-", broken, claims.AtMost("x", 1.0), "{x}"))
    frame = claims.reproduce(ids=["annen08.broken"], progress=False)
    assert frame["verdict"].tolist() == ["error"] and "boom" in frame["note"].iloc[0]


def test_compare_expected_reports_a_changed_verdict_with_both_values(tmp_path, monkeypatch):
    value = {"x": 0.5}
    monkeypatch.setitem(claims.CLAIMS, "annen08.synthetic", claims.Claim(
        "annen08.synthetic", claims.PAPERS["annen08"], "nowhere", "x is small", "x <= 1",
        lambda tier: claims.Measured(dict(value)), claims.AtMost("x", 1.0), "{x:.2f}"))
    recorded = claims.reproduce(ids=["annen08.synthetic"], progress=False)
    path = claims.record_expected(recorded, tmp_path / "expected.csv")
    assert claims.compare_expected(claims.reproduce(ids=["annen08.synthetic"], progress=False), path) == []
    value["x"] = 1.5
    problems = claims.compare_expected(claims.reproduce(ids=["annen08.synthetic"], progress=False), path)
    assert any("'refuted'" in p and "'holds'" in p and "1.5" in p and "0.5" in p for p in problems)


@pytest.mark.parametrize("tolerance, remeasured, reported", [
    ({"speedup": claims.TIMING}, 0.9, False),  # a time ratio: the machine's load, never a test failure
    ({"speedup": claims.TIMING}, 1.9, False),
    ({}, 0.9, True),  # a deterministic value: every flip is a change
])
def test_a_verdict_that_timing_noise_flips_is_no_change(tmp_path, monkeypatch, tolerance, remeasured, reported):
    value = {"speedup": 0.7}
    monkeypatch.setitem(claims.CLAIMS, "marrs18.synthetic", claims.Claim(
        "marrs18.synthetic", claims.PAPERS["marrs18"], "nowhere", "faster", "x <= 0.8",
        lambda tier: claims.Measured(dict(value)), claims.AtMost("speedup", 0.8, in_kind=1.25), "{speedup:.2f}",
        tolerance=tolerance))
    path = claims.record_expected(claims.reproduce(ids=["marrs18.synthetic"], progress=False), tmp_path / "expected.csv")
    value["speedup"] = remeasured
    problems = claims.compare_expected(claims.reproduce(ids=["marrs18.synthetic"], progress=False), path)
    assert any("verdict" in p for p in problems) == reported, problems


def test_report_has_one_table_per_paper_and_the_csv(tmp_path, monkeypatch):
    for key in ("annen08", "marrs18"):
        monkeypatch.setitem(claims.CLAIMS, f"{key}.synthetic", claims.Claim(
            f"{key}.synthetic", claims.PAPERS[key], "Figure 1", "a claim", "2x",
            lambda tier: claims.Measured({"x": 3.0}), claims.AtMost("x", 2.0, in_kind=4.0), "{x:.1f}x"))
    frame = claims.reproduce(ids=["annen08.synthetic", "marrs18.synthetic"], out=tmp_path, progress=False)
    text = (tmp_path / "claims.md").read_text()
    assert text.count("| claim | where | the paper | ours | verdict |") == 2
    assert "Annen et al. 2008" in text and "Marrs et al. 2018" in text and "**holds in kind**" in text
    table = pd.read_csv(tmp_path / "claims.csv")
    assert table["verdict"].tolist() == ["holds in kind", "holds in kind"] and len(frame) == 2


# --- the registry ------------------------------------------------------------------------------

def test_the_section_beyond_the_papers_follows_them_in_the_report_and_the_readme(tmp_path, monkeypatch):
    for key in ("beyond", "annen08"):
        monkeypatch.setitem(claims.CLAIMS, f"{key}.synthetic", claims.Claim(
            f"{key}.synthetic", claims.SECTIONS[key], "somewhere", "a claim", "2x",
            lambda tier: claims.Measured({"x": 1.0}), claims.AtMost("x", 2.0), "{x:.1f}x"))
    frame = claims.reproduce(ids=["beyond.synthetic", "annen08.synthetic"], out=tmp_path, progress=False)
    text = (tmp_path / "claims.md").read_text()
    assert text.index("## Annen et al. 2008: Real-time") < text.index("## Beyond the papers\n\n" + claims.BEYOND.about)
    readme = tmp_path / "README.md"
    readme.write_text("\n".join(["# Claims", *ledger.README_MARKERS, ""]))
    claims.update_readme(frame, readme)
    assert readme.read_text().splitlines()[2:4] == ["- **Annen et al. 2008**, *Real-time, All-Frequency Shadows in Dynamic Scenes*: "
                                                    "1 holds.", "- **Beyond the papers**: 1 holds."]
    assert claims.reproduce(papers="beyond", ids=["beyond.synthetic"], progress=False)["paper"].tolist() == ["beyond"]
    with pytest.raises(ValueError, match="'beyond'"):
        claims.claim("nobody.synthetic", where="-", statement="-", paper_value="-", rule=claims.AtMost("x", 1.0), ours="-")


def test_every_section_has_claims_and_every_claim_is_well_formed():
    assert {c.paper.key for c in claims.CLAIMS.values()} == set(claims.SECTIONS)
    for c in claims.CLAIMS.values():
        assert c.id.startswith(c.paper.key + ".") and c.where and c.statement and c.paper_value and c.ours
        assert "seed 00" not in c.statement + c.where + c.paper_value


def test_no_verdict_reads_an_absolute_time():
    """Absolute seconds depend on the machine; a verdict must rest on ratios measured side by side."""
    for c in claims.CLAIMS.values():
        clocked = {k for k, t in c.tolerance.items() if t.absolute}
        assert not clocked & set(ledger._rule_keys(c.rule)), c.id


def test_the_cli_refuses_an_unknown_paper_with_the_known_ones(capsys):
    from softshadows import cli

    with pytest.raises(SystemExit):
        cli.main(["reproduce", "--papers", "nobody99", "--out", "/nonexistent/never"])
    assert "sintorn08" in capsys.readouterr().err


# --- the fast tier against its recorded values --------------------------------------------------

@lru_cache(maxsize=1)
def fast_tier():
    return claims.reproduce(tier="fast", progress=False)


def recorded_ids():
    return list(dict.fromkeys(pd.read_csv(EXPECTED, comment="#")["id"])) if EXPECTED.exists() else []


def test_every_claim_is_recorded():
    missing = sorted(set(claims.CLAIMS) - set(recorded_ids()))
    assert not missing, f"not in {EXPECTED.name}: {missing}; run `softshadows reproduce --tier fast --record tests/claims/expected.csv`"


@pytest.mark.parametrize("claim_id", recorded_ids())
def test_fast_tier_matches_its_recorded_measurement(claim_id):
    frame = fast_tier()
    row = frame[frame["id"] == claim_id]
    assert not row.empty, f"{claim_id} is recorded but no longer in the ledger"
    assert row["verdict"].iloc[0] in claims.VERDICTS, row["note"].iloc[0]
    problems = [p for p in claims.compare_expected(row, EXPECTED) if p.startswith(claim_id + ":")]
    assert not problems, "\n".join(problems)


@pytest.mark.parametrize("share, reported", [
    (1.0, False),  # the exactness unchanged, the timing within its noise: the load flipped it
    (0.9, True),  # the exactness changed: a change, whatever the timing
])
def test_a_rule_of_a_timing_and_an_exact_value_flips_on_timing_noise_only(tmp_path, monkeypatch, share, reported):
    value = {"speedup": 1.4, "identical_share": 1.0}
    rule = claims.AllOf(claims.AtLeast("identical_share", 0.99), claims.Between("speedup", 1.0, 1.3, in_kind=(0.5, 5)))
    monkeypatch.setitem(claims.CLAIMS, "marrs18.synthetic", claims.Claim(
        "marrs18.synthetic", claims.PAPERS["marrs18"], "nowhere", "exact and faster", "x", lambda tier: claims.Measured(dict(value)),
        rule, "{speedup:.2f}", tolerance={"speedup": claims.TIMING}))
    path = claims.record_expected(claims.reproduce(ids=["marrs18.synthetic"], progress=False), tmp_path / "expected.csv")
    value.update(speedup=1.2, identical_share=share)  # 'holds in kind' recorded, 'holds' now
    problems = claims.compare_expected(claims.reproduce(ids=["marrs18.synthetic"], progress=False), path)
    assert any("verdict" in p for p in problems) == reported, problems
