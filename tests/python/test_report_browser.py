"""The validation report in a real browser (headless Chromium): its summary
table and every image render; a broken image or a missing table fails. The
report is built from a synthetic two-row box case, so the page's structure is
tested without running any engine (the CI's quick suite checks its own real
report the same way, scripts/test.sh)."""
import json
import os
from pathlib import Path

import numpy as np
import pytest

from compare.browser_check import check, chromium
from compare.report_html import write_report
from compare.validate import binomial, compare_rows, summary

ROOT = Path(__file__).resolve().parents[2]
OUT = Path(os.environ.get("TEST_OUTPUT_DIR", ROOT / "build" / "test_output"))

pytestmark = pytest.mark.skipif(chromium() is None, reason="chromium not installed (scripts/test.sh installs it)")


def fake_run(seed, phi_scale, convecting, rng):
    h = np.linspace(0.5, 55, 40)
    return {"seed": seed, "ok": True, "path": "", "wall_seconds": 10.0, "particle_steps_per_second": 1e7,
            "phi_max": 37.0 * phi_scale + rng.normal(0, 0.5), "convecting": convecting, "bed_height": 55.6,
            "phi_heights": h.tolist(), "phi": (phi_scale * 37 * np.sin(np.pi * h / 55)).tolist(),
            "rose": False, "height_t": [2.0, 4.0, 6.0], "height": [4.0, 4.2, 4.1], "coulomb_at_cap": 2e-4}


def synthetic_report():
    rng = np.random.default_rng(1)
    variants = {}
    for f, scale, conv in (("2.6Hz", 0.02, False), ("3.2Hz", 1.0, True)):
        rows = {}
        for row in ("native-leapfrog", "lammps"):
            runs = [fake_run(s, scale, conv, rng) for s in (1, 2, 3)]
            rows[row] = {"runs": runs, "failed_runs": [], "speed": 1e7,
                         "summary": {k: summary([r[k] for r in runs]) for k in ("bed_height", "phi_max")},
                         "convection": binomial(sum(r["convecting"] for r in runs), 3), "rise": binomial(0, 3)}
        variants[f] = rows
    comps = []
    for f, rows in variants.items():
        a, b = rows["native-leapfrog"], rows["lammps"]
        base = {"case": "box", "variant": f, "a_row": "native-leapfrog", "b_row": "lammps", "gating": True,
                "why": "same model"}
        if f == "3.2Hz":
            comps.append(base | compare_rows("phi_max", a["runs"], b["runs"]))
        comps.append(base | compare_rows("convecting", a["runs"], b["runs"]))
    return {"suite": "quick", "created": "test", "cases": {"box": {
        "kind": "box", "scene": "scenes/box/f3.0_big.toml", "sets": ["run.duration=8"], "seeds": [1, 2, 3],
        "variants": variants}}, "comparisons": comps, "verdict": "pass", "failures": [], "power_target": 0.8,
        "thresholds": [], "design": []}


def test_report_renders_table_and_images(tmp_path):
    page = write_report(synthetic_report(), tmp_path)
    assert page == tmp_path / "report.html" and page.exists()  # named after the report, not after a case
    res = check(page, screenshot=OUT / "report_screenshot.png")
    assert res["rows"] == 3
    assert res["images_total"] == 3 and res["images_loaded"] == 3  # Phi(D), heights, threshold
    assert Path(res["screenshot"]).stat().st_size > 10_000


def test_a_broken_image_is_caught(tmp_path):
    page = write_report(synthetic_report(), tmp_path)
    (tmp_path / "box_phi.png").unlink()
    with pytest.raises(RuntimeError, match="1 of 3 images did not load"):
        check(page)


def test_a_page_without_its_table_is_caught(tmp_path):
    page = write_report(synthetic_report(), tmp_path)
    text = page.read_text().replace("<table id='summary'>", "<table>")
    page.write_text(text)
    with pytest.raises(RuntimeError, match="no summary table"):
        check(page)
