"""The Table I report: rows, the friction-rule check and figures from a
directory of runs (synthetic here, with known outcomes)."""
import json

import h5py
import numpy as np

from compare.table1 import paper_rule, table1
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
    assert "8→8" in row_c and "yes / yes" in row_c and row_c.endswith("✓ |")
    assert "(running)" in row_f  # no .done marker
    assert "no / no" in row_f and row_f.endswith("✓ |")
    assert "Not run yet" in text and "#A" in text
    assert (tmp_path / "figs" / "C_spacetime.png").stat().st_size > 1000
