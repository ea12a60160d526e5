"""compare grid: grouping runs by set-up and frequency, the rise and convection
counts, and the verdict against a reference set-up (margins of
docs/tolerances.md). The observables themselves are tested elsewhere; here they
are fixed per file so the bookkeeping is what is checked."""
import pytest

import compare.grid as grid

PHI = {"ref": 40.0, "close": 37.0, "far": 20.0}  # margin 3.6 grains per cycle: close is within, far is not


@pytest.fixture
def runs(tmp_path, monkeypatch):
    paths = []
    for setup in PHI:
        for f in (2.6, 3.2):
            for s in (1, 2, 3):
                p = tmp_path / f"{setup}_f{f}_s{s}.h5"
                p.write_bytes(b"")
                if not (setup == "close" and s == 3 and f == 2.6):  # one unfinished run
                    (tmp_path / (p.name + ".done")).write_bytes(b"")
                paths.append(p)

    def fake_obs(path):
        setup, f, s = grid.parse(path)
        rose = f > 3 and (setup != "far" or s == 1)
        return {"phi_max": PHI[setup] + 0.1 * s, "bed_height": 55.0 + 0.01 * s, "rose": rose, "convecting": f > 3}

    monkeypatch.setattr(grid, "box_observables", fake_obs)
    monkeypatch.setattr(grid, "kind_of", lambda p: "box")
    return paths


def test_groups_counts_and_reference_verdict(runs):
    rep = grid.grid(runs, reference="ref")
    rows = {(r["setup"], r["frequency"]): r for r in rep["rows"]}
    assert len(rows) == 6
    assert len(rep["skipped_unfinished"]) == 1
    assert len(rows[("close", 2.6)]["runs"]) == 2
    assert rows[("ref", 3.2)]["rose"]["k"] == 3 and rows[("far", 3.2)]["rose"]["k"] == 1
    assert rows[("ref", 3.2)]["summary"]["phi_max"]["mean"] == pytest.approx(40.2)
    close, far = rows[("close", 3.2)]["against_reference"], rows[("far", 3.2)]["against_reference"]
    assert close["phi_max"]["within"] and not far["phi_max"]["within"]
    assert close["bed_height"]["within"] and far["bed_height"]["within"]
    assert close["rose"]["overlap"]  # 3/3 against 3/3
    assert far["rose"]["overlap"]    # 1/3 against 3/3: three packings cannot tell them apart
    text = grid.markdown(rep)
    assert "far at 3.2 Hz phi_max differs by -20" in text and "close at 3.2 Hz phi_max" not in text
    assert "1 unfinished run(s) left out" in text


def test_a_misnamed_run_is_refused(tmp_path):
    p = tmp_path / "whatever.h5"
    p.write_bytes(b"")
    (tmp_path / "whatever.h5.done").write_bytes(b"")
    with pytest.raises(SystemExit, match="whatever.h5: not named"):
        grid.grid([p])
