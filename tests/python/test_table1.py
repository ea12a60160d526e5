"""The Table I report: rows, the friction-rule check and figures from a
directory of runs (synthetic here, with known outcomes)."""
import json

import h5py
import numpy as np

import pytest

from compare.table1 import paper_rule, parse_paper_bands, section_v_lines, table1, verdict
from synthetic import banded_y, random_bed, species_and_diameters, write_drum_run


def _with_scene(path, rid, friction, paper_bands):
    with h5py.File(path, "r+") as f:
        scene = json.loads(f.attrs["scene_json"])
        scene["scene"]["name"] = rid
        scene["paper"] = {"N": 4664, "rotations": 500.0, "bands": paper_bands}
        scene["friction"] = dict(zip(("gamma_s_bb", "gamma_s_ss", "gamma_s_bw", "gamma_s_sw"), friction))
        scene["particles"] = {"fill_density": 0.3, "big_diameter": 1.3, "initial_state": "mixed"}
        f.attrs["scene_json"] = json.dumps(scene)
        f.attrs["scene_name"] = rid


def _c_and_f_runs(tmp_path, seed):
    """tmp_path/runs with C, which segregates (bands from rotation 5 on) and
    is done, and F, which stays mixed and is not done; both as Table I says."""
    rng = np.random.default_rng(seed)
    n = 4664
    sp, d = species_and_diameters(rng, n)
    runs = tmp_path / "runs"
    runs.mkdir()
    banded = [random_bed(rng, n) for _ in range(5)] + [random_bed(rng, n, y=banded_y(rng, sp, 8)) for _ in range(30)]
    write_drum_run(runs / "C.h5", np.array(banded), sp, d)
    _with_scene(runs / "C.h5", "C", (2, 2, 10, 2), "8")
    (runs / "C.h5.done").touch()
    write_drum_run(runs / "F.h5", np.array([random_bed(rng, n) for _ in range(35)]), sp, d)
    _with_scene(runs / "F.h5", "F", (2, 10, 2, 10), "none")
    return runs


def test_paper_rule():
    rule = lambda bb, ss, bw, sw: paper_rule(dict(gamma_s_bb=bb, gamma_s_ss=ss, gamma_s_bw=bw, gamma_s_sw=sw))
    assert rule(10, 2, 10, 2) and rule(2, 10, 10, 2) and rule(10, 2, 10, 10)
    assert not rule(2, 2, 2, 10) and not rule(10, 2, 2, 10) and not rule(2, 10, 10, 10)


def test_report_rows_and_rule_check(tmp_path):
    runs = _c_and_f_runs(tmp_path, seed=7)
    out = table1(runs, tmp_path / "t1.md", tmp_path / "figs")
    text = out.read_text()
    row_c = next(l for l in text.splitlines() if l.startswith("| C |"))
    row_f = next(l for l in text.splitlines() if l.startswith("| F |"))
    assert "8→8" in row_c and "yes / yes" in row_c and "✓ |" in row_c and row_c.endswith("| agree: counts within one band pair |")
    assert "(running)" in row_f  # no .done marker
    assert "no / no" in row_f and "✓ |" in row_f and "| open: the run has not reached" in row_f
    assert "Not run yet" in text and "#A" in text
    assert (tmp_path / "figs" / "C_spacetime.png").stat().st_size > 1000
    # the machine-readable summary beside it
    summary = {r["run"]: r for r in json.loads((tmp_path / "t1.json").read_text())["runs"]}
    assert set(summary) == set("ABCDEFGHIJKLMNPQRSTUVWXY")  # the missing ones from their scene files
    assert summary["A"]["verdict"] == "open" and summary["A"]["reason"] == "not started"
    c = summary["C"]
    assert c["done"] and c["verdict"] == "agree" and c["bands_final"] == 8 and c["paper"]["bands"] == "8"
    assert c["rotations_reached"] > 0 and c["formation_rotations"] is not None
    assert summary["F"]["verdict"] == "open" and summary["F"]["bands_final"] == 0


def test_verdict_rules():
    """Table I's x->y against ours: the final count within one pair, the
    direction of change, segregated or not; unfinished runs stay open."""
    merge = [{"rotation": 900.0, "from": 8, "to": 6, "kind": "merge"}]
    assert verdict((8, 6), 8, 6, merge, True)[0] == "agree"
    assert verdict((8, 6), 8, 6, [], True) == ("disagree", "the paper's 8->6 needs a lasting merge; none here")
    assert verdict((8, 6), 8, 10, merge, True)[0] == "disagree"
    assert verdict((2, 6), 2, 6, [{"rotation": 5.0, "from": 2, "to": 6, "kind": "split"}], True)[0] == "agree"
    assert verdict((0, 0), 2, 2, [], True)[0] == "disagree"  # the paper mixed, we segregate
    assert verdict((8, 6), 8, 6, merge, False)[0] == "open"
    assert parse_paper_bands("19->11") == (19, 11) and parse_paper_bands("6") == (6, 6)
    assert parse_paper_bands("none") == (0, 0) and parse_paper_bands("") is None


def test_earlier_report_stands_in_until_a_run_is_made_again(tmp_path):
    """--earlier: an earlier report's finished runs fill the rows of runs the
    directory has not finished, with their commit, values and figures; a run
    made again replaces its earlier row only once it is done."""
    # F made again but not finished: the earlier finished F stands in
    runs = _c_and_f_runs(tmp_path, seed=11)

    def earlier_row(rid, bands, done=True, **kw):
        r = {"run": rid, "commit": "0123456789abcdef", "done": done, "rotations_requested": 500.0,
             "rotations_reached": 500.0 if done else 12.0, "dt": 0.01, "particles": 4664,
             "paper": {"bands": bands, "rotations": 500.0, "N": 4664, "figure": ""},
             "bands_first_50": 6, "bands_early": 6, "bands_final": 4, "formation_rotations": 31.0,
             "events": [{"rotation": 140.0, "from": 6, "to": 4, "kind": "merge"}], "slope_deg": 15.0,
             "verdict": "agree", "reason": "counts within one band pair", "section_v": {}}
        r.update(kw)
        return r
    earlier = tmp_path / "earlier.json"
    earlier.write_text(json.dumps({"runs": [
        earlier_row("C", "8", bands_final=99),           # the directory's finished C wins
        earlier_row("D", "6"),                           # D absent from the directory: kept
        earlier_row("F", "none", bands_early=0, bands_final=0, formation_rotations=None, events=[],
                    verdict="agree", reason="earlier F"),
        earlier_row("A", "8->6", done=False),            # unfinished earlier runs are not kept
    ]}))
    figs = tmp_path / "figs"
    figs.mkdir()
    (figs / "D_spacetime.png").write_bytes(b"\x89PNG earlier figure")
    out = table1(runs, tmp_path / "t1.md", figs, earlier=earlier)
    text = out.read_text()
    rows = {}  # the main table's row of each run (the friction-rule table's come later)
    for l in text.splitlines():
        if l.startswith("| ") and l[2] in "ACDF" and l[3] == " ":
            rows.setdefault(l[2], l)
    assert "| 8→8 |" in rows["C"]  # from the directory, not the earlier 99
    assert "| 6→4 | 31 | yes / yes | ✓ | 6→4 at 140 | agree: counts within one band pair |" in rows["D"]
    assert "| 500 | 500 |" in rows["D"] and "| 0→0 |" in rows["F"] and rows["F"].endswith("| agree: earlier F |")
    assert "(running)" not in rows["F"]
    assert "| open: not started |" in rows["A"]
    assert "made by commit 0123456 and not yet made again to the paper's length here: #D, #F." in text
    assert "![D](figs/D_spacetime.png)" in text  # the earlier figure is kept, not redrawn
    assert (figs / "D_spacetime.png").read_bytes() == b"\x89PNG earlier figure"
    # the friction-rule table covers the kept runs too
    assert any(l.startswith("| D | 10 | 10 | 10 | 2 |") for l in text.splitlines())
    summary = {r["run"]: r for r in json.loads((tmp_path / "t1.json").read_text())["runs"]}
    assert summary["D"]["commit"] == "0123456789abcdef" and summary["D"]["bands_final"] == 4
    assert summary["F"]["reason"] == "earlier F" and summary["C"]["bands_final"] == 8
    assert summary["A"]["verdict"] == "open"


def test_section_v_rows_pattern_motion_and_odd_counts():
    """The band-speed row labels each run by its ends; the odd-count row takes
    only the capped runs that start mixed (#X starts as two halves)."""
    def summary(rid, done=True, **sv):
        return {"run": rid, "done": done, "rotations_reached": 1000.0, "rotations_requested": 1000.0,
                "bands_final": sv.pop("bands", 2), "events": [], "section_v": sv}
    rows = section_v_lines([
        summary("A", band_speed_median=0.0066, band_speed_tracks=10, pattern_excursion=8.0,
                pattern_wavelength=32.0, pattern_rotations=900.0),
        summary("R", bands=5, ends_last_tenth=["big", "big"], band_speed_median=None, band_speed_tracks=0,
                onset_interior=[13.5, 15.5, 18.3], onset_interior_bands=4, onset_ends=[34.3, None]),
        summary("X", done=False, ends_last_tenth=["small", "big"], band_speed_median=5.6e-5, band_speed_tracks=2,
                interface_width_first_tenth=12.8, interface_width_last_tenth=12.3),
    ])
    motion = [r for r in rows if r.startswith("| capped patterns stay still")]
    assert len(motion) == 1
    assert ("#A (periodic) band speed 0.0066 d per rotation (10 boundaries), wanders over 8.0 = 0.25 of the "
            "alternate-band spacing in 900 rotations; #X (capped) band speed 5.6e-05 d per rotation") in motion[0]
    # judged on the capped run alone, which is still running
    assert motion[0].endswith("| #X (running) |") and "#R" not in motion[0] and "| open: #X not at" in motion[0]
    wander = [r for r in rows if r.startswith("| #A's pattern wanders")]
    assert len(wander) == 1 and "| agree: #A agree: 0.25 of the alternate-band spacing | #A |" in wander[0]
    odd = [r for r in rows if r.startswith("| capped runs: odd band counts")]
    assert len(odd) == 1 and "#R 5 bands, ends big/big" in odd[0] and "#X" not in odd[0]
    nucl = [r for r in rows if r.startswith("| capped runs: formation begins")]
    assert len(nucl) == 1 and nucl[0].endswith("| #R |")
    assert "#R: interior bands begin at rotations 14, 16, 18 (3 of 4), the end bands at 34 and never" in nucl[0]


def test_no_slope_from_the_starting_lattice_alone(tmp_path):
    """A long run with a sparse snapshot cadence has, early on, only its
    starting snapshot: no slope is reported from it (the settled C run has one)."""
    rng = np.random.default_rng(3)
    n = 4664
    sp, d = species_and_diameters(rng, n)
    runs = tmp_path / "runs"
    runs.mkdir()
    period = 2 * np.pi / 0.5
    write_drum_run(runs / "D.h5", np.array([random_bed(rng, n) for _ in range(3)]), sp, d,
                   times=np.array([0.0, 0.5, 1.5]) * period)
    _with_scene(runs / "D.h5", "D", (10, 2, 10, 2), "8->6")
    write_drum_run(runs / "C.h5", np.array([random_bed(rng, n) for _ in range(6)]), sp, d)
    _with_scene(runs / "C.h5", "C", (2, 2, 10, 2), "8")
    table1(runs, tmp_path / "t1.md", tmp_path / "figs")
    summary = {r["run"]: r for r in json.loads((tmp_path / "t1.json").read_text())["runs"]}
    assert summary["D"]["slope_deg"] is None
    assert summary["C"]["slope_deg"] is not None


def test_section_v_blur_row_reports_contrast_width_and_formation():
    """#P and #Q's blur (Sec. V.C) is read from the contrast, the interface
    width and the formation time, beside #A's; one run alone gives no row."""
    def summary(rid, formation, contrast, width, done=True):
        return {"run": rid, "done": done, "rotations_reached": 1000.0, "rotations_requested": 1000.0,
                "bands_final": 6, "events": [], "formation_rotations": formation,
                "section_v": {"contrast_last_tenth": contrast, "interface_width_last_tenth": width}}
    assert not [r for r in section_v_lines([summary("A", 18.0, 0.319, 10.2)]) if "fuller drums" in r]
    rows = [r for r in section_v_lines([summary("A", 18.0, 0.319, 10.2), summary("P", 20.0, 0.176, 13.2),
                                        summary("Q", None, 0.076, 32.0, done=False)]) if "fuller drums" in r]
    assert len(rows) == 1
    assert "#A contrast 0.319, interface width 10.2, bands formed at rotation 18" in rows[0]
    assert "#Q contrast 0.076, interface width 32.0, bands formed at rotation –" in rows[0]
    assert rows[0].endswith("| #A, #P, #Q (running) |")


def test_a_running_run_is_open_not_a_disagreement():
    from compare.table1 import _mark
    assert _mark(True, True, done=False) == "✓"
    assert _mark(True, False, done=False) == "open"  # bands may still form
    assert _mark(True, False) == "✗"


def test_section_v_claims_carry_verdicts_and_a_running_run_keeps_its_claim_open():
    """Every claim row has a verdict; a run short of the paper's length leaves
    its claim open whatever its measures say so far, and #V is not judged by
    the wander rule (the paper gives its two bands "excessive motion")."""
    from compare.table1 import section_v_claims

    def summary(rid, done=True, **sv):
        return {"run": rid, "done": done, "rotations_reached": 1000.0, "rotations_requested": 1000.0,
                "bands_final": sv.pop("bands", 2), "events": [], "section_v": sv}
    v_mixing = dict(interface_width_first_tenth=12.0, interface_width_last_tenth=40.0, mixing_time=None,
                    band_speed_median=0.03, band_speed_tracks=1, pattern_excursion=64.0,
                    pattern_wavelength=64.0, pattern_rotations=900.0)
    claims = {c["claim"]: c for c in section_v_claims([summary("V", **v_mixing)])}
    assert claims['#V: "no hint of mixing"']["verdict"] == "disagree"
    assert not [c for c in claims if c.startswith("periodic patterns")]
    claims = {c["claim"]: c for c in section_v_claims([summary("V", done=False, **v_mixing)])}
    c = claims['#V: "no hint of mixing"']
    assert c["verdict"] == "open" and c["running"] == ["V"] and "so far: disagree" in c["reason"]
    rows = section_v_lines([summary("V", **v_mixing)])
    assert rows[-2] == "|---|---|---|---|" and "| disagree: interface width +233%" in rows[-1]


def test_verdict_summary_counts_each_verdict_once():
    from compare.table1 import verdict_summary
    runs = [{"run": "A", "verdict": "agree"}, {"run": "L", "verdict": "disagree"}, {"run": "J", "verdict": "open"},
            {"run": "C", "verdict": "agree"}]
    claims = [{"name": "#Y exchange", "verdict": "disagree"}, {"name": "#X no mixing", "verdict": "agree"}]
    line = verdict_summary(runs, claims)[-1]
    assert "agree 2 (#A, #C); disagree 1 (#L); open 1 (#J)." in line
    assert "Section V's claims (below): agree 1 (#X no mixing); disagree 1 (#Y exchange)." in line
