"""The Table I report: rows, the friction-rule check and figures from a
directory of runs (synthetic here, with known outcomes)."""
import json

import h5py
import numpy as np

import pytest

from compare.table1 import paper_rule, parse_paper_bands, table1, verdict
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


def test_paper_rule():
    rule = lambda bb, ss, bw, sw: paper_rule(dict(gamma_s_bb=bb, gamma_s_ss=ss, gamma_s_bw=bw, gamma_s_sw=sw))
    assert rule(10, 2, 10, 2) and rule(2, 10, 10, 2) and rule(10, 2, 10, 10)
    assert not rule(2, 2, 2, 10) and not rule(10, 2, 2, 10) and not rule(2, 10, 10, 10)


def test_report_rows_and_rule_check(tmp_path):
    rng = np.random.default_rng(7)
    n = 4664
    sp, d = species_and_diameters(rng, n)
    runs = tmp_path / "runs"
    runs.mkdir()
    # C: segregates (bands from rotation 5 on); F: stays mixed. Both as Table I says.
    banded = [random_bed(rng, n) for _ in range(5)] + [random_bed(rng, n, y=banded_y(rng, sp, 8)) for _ in range(30)]
    write_drum_run(runs / "C.h5", np.array(banded), sp, d)
    _with_scene(runs / "C.h5", "C", (2, 2, 10, 2), "8")
    (runs / "C.h5.done").touch()
    write_drum_run(runs / "F.h5", np.array([random_bed(rng, n) for _ in range(35)]), sp, d)
    _with_scene(runs / "F.h5", "F", (2, 10, 2, 10), "none")
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
