"""``report.html`` of identify, update and direct: self-contained (parsed here), findings first, embedded figures."""

import base64
import json
from html.parser import HTMLParser

import numpy as np
import pytest

from jointid.cli.main import main
from study_texts import beam_study_toml


class _Page(HTMLParser):
    """Sections (id -> text), list items per section, images, and every URL-bearing attribute."""

    def __init__(self):
        super().__init__()
        self.sections, self.items, self.images, self.urls, self.tags = {}, {}, [], [], set()
        self._section = None
        self._li = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.add(tag)
        for key in ("src", "href", "action", "data", "poster", "background"):
            if key in a:
                self.urls.append(a[key])
        if tag == "section":
            self._section = a["id"]
            self.sections[self._section] = ""
            self.items[self._section] = []
        elif tag == "li" and self._section:
            self._li = ""
        elif tag == "img":
            self.images.append(a["src"])

    def handle_endtag(self, tag):
        if tag == "li" and self._li is not None:
            self.items[self._section].append(self._li)
            self._li = None
        elif tag == "section":
            self._section = None

    def handle_data(self, data):
        if self._section:
            self.sections[self._section] += data
        if self._li is not None:
            self._li += data


def parse_report(path) -> _Page:
    """Parse ``path`` and check it is self-contained: no script, style sheet, frame or URL outside the page."""
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    page.close()
    assert not page.tags & {"script", "link", "iframe", "object", "embed"}
    for url in page.urls:
        assert url.startswith("#") or url.startswith("data:image/png;base64,"), url
    for src in page.images:
        assert base64.b64decode(src.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
    return page


def test_identify_writes_a_self_contained_report_with_findings_first(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(beam_study_toml(start=5.0, stop=1000.0, step=10.0))
    assert main(["simulate", str(study), "--out", str(tmp_path / "sim"), "--noise", "0.03", "--seed", "2"]) == 0
    capsys.readouterr()
    assert main(["identify", str(study), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id")]) == 0
    printed = capsys.readouterr().out.splitlines()
    page = parse_report(tmp_path / "id" / "report.html")
    assert list(page.sections) == ["findings", "terms", "trust", "inputs"]  # the findings first
    summary = json.loads((tmp_path / "id" / "summary.json").read_text())
    assert summary["findings"], "3 % noise: some term is not identifiable somewhere (the test needs a finding)"
    for finding in summary["findings"]:
        assert finding in page.items["findings"]
    # the printed per-term lines are the report's, and every independent term is there with its unit
    terms = [x for x in printed if x.startswith("K_") and "median |K|" in x]
    assert [x.split(":")[0] for x in terms] == ["K_w_w", "K_w_theta", "K_theta_theta"]
    assert all(t in page.items["findings"] for t in terms)
    for name, unit in (("K_w_w", "N/m"), ("K_w_theta", "N/rad"), ("K_theta_theta", "N*m/rad")):
        assert name in page.sections["findings"] and unit in page.sections["findings"]
    assert len(page.images) == 1 and "joint_stiffness.png" in page.sections["terms"]
    assert base64.b64decode(page.images[0].split(",", 1)[1]) == (tmp_path / "id" / "joint_stiffness.png").read_bytes()
    assert "90 % band" in page.sections["trust"] and "reliable_*" in page.sections["trust"]
    assert "frf.uff" in page.sections["inputs"] and "1w, 3w, 6w, 9w, 12w, 15w, 19w" in page.sections["inputs"]
    assert "SI units, no record skipped" in page.sections["inputs"]
    # reliable_* columns are 0/1: numpy reads them as numbers (true/false would be NaN, which is truthy)
    table = np.genfromtxt(tmp_path / "id" / "joint_stiffness.csv", delimiter=",", names=True)
    flags = table["reliable_theta_theta"]
    assert set(np.unique(flags)) <= {0.0, 1.0} and 0 < flags.mean() <= 1
    assert np.array_equal(table["reliable"], table["reliable_w_w"] * table["reliable_w_theta"] * table["reliable_theta_w"] * flags)


def test_identify_report_names_the_records_skipped(tmp_path, capsys):
    """A file with more responses than the study observes: the report's inputs say what was skipped, as the console does."""
    study = tmp_path / "study.toml"
    text = beam_study_toml(start=100.0, stop=400.0, step=10.0)
    study.write_text(text)
    assert main(["simulate", str(study), "--out", str(tmp_path / "sim")]) == 0
    fewer = tmp_path / "fewer.toml"
    fewer.write_text(text.replace("observed = [1, 3, 6, 9, 12, 15, 19]", "observed = [1, 3, 6, 12, 15, 19]"))
    capsys.readouterr()
    assert main(["identify", str(fewer), "--frf", str(tmp_path / "sim" / "frf.uff"), "--out", str(tmp_path / "id"), "--no-plots"]) == 0
    notes = [x.split(": ", 1)[1] for x in capsys.readouterr().out.splitlines() if x.startswith(f"{tmp_path / 'sim' / 'frf.uff'}: ")]
    assert notes and any("skipped" in n for n in notes)
    page = parse_report(tmp_path / "id" / "report.html")
    assert page.items["inputs"] == notes
    assert page.images == [] and "--no-plots" in page.sections["terms"]


def test_update_and_direct_write_reports(tmp_path):
    study = tmp_path / "study.toml"
    text = beam_study_toml(start=20.0, stop=1000.0, step=20.0)
    study.write_text(text + "\n[truth]\nelastic_modulus = 70e9\n")
    assert main(["simulate", str(study), "--free", "--noise", "0.01", "--seed", "1", "--out", str(tmp_path / "sim")]) == 0
    assert main(["update", str(study), "--frf", str(tmp_path / "sim" / "free_frf.uff"), "--out", str(tmp_path / "upd")]) == 0
    page = parse_report(tmp_path / "upd" / "report.html")
    assert list(page.sections) == ["findings", "figures", "trust", "inputs"]
    report = json.loads((tmp_path / "upd" / "update.json").read_text())
    for name in report["parameters"]:
        assert name in page.sections["findings"]
    assert any(x.startswith("residual (rms |ln(H_model / H_measured)|)") for x in page.items["findings"])
    assert len(page.images) == 1

    ex = tmp_path / "ex.csv"
    assert main(["direct", "--example", str(ex)]) == 0
    assert main(["direct", str(ex), "--out", str(tmp_path / "dir")]) == 0
    page = parse_report(tmp_path / "dir" / "report.html")
    assert list(page.sections) == ["findings", "figures", "trust", "inputs"]
    assert page.items["findings"][0].startswith("direct: 60 lines (0 flagged), E = ")
    assert "elastic_modulus_pa" in page.sections["findings"] and len(page.images) == 1


def test_trust_section_gives_a_verdict_per_term():
    from jointid.report.identification import trust_items

    terms = {
        "K_w_w": {"median_magnitude": 1e5, "reliable_fraction": 1.0, "median_predicted_relative_std": 0.0013},
        "K_w_theta": {"median_magnitude": 800.0, "reliable_fraction": 0.84, "median_predicted_relative_std": 0.014},
        "K_theta_w": {"median_magnitude": 800.0, "reliable_fraction": 0.84, "median_predicted_relative_std": 0.014},
        "K_theta_theta": {"median_magnitude": 15.0, "reliable_fraction": 0.0, "median_predicted_relative_std": 0.5},
    }
    items = trust_items({"method": "receptance", "options": {"max_relative_std": 0.1}, "terms": terms})
    assert items[:3] == [
        "Trust K_w_w over the whole band: reliable on every line, median predicted error 0.13 %.",
        "Trust K_w_theta only where it is reliable: on 84 % of the lines, median predicted error 1.4 %; "
        "the findings name the bands to leave out.",
        "Do not use K_theta_theta: these FRFs determine it on no line.",
    ]
    assert items[3].startswith("Reliable means: the predicted relative error (1 sigma) of the term is at most 10 % ")


def test_titled_lists_render_and_an_empty_one_is_left_out(tmp_path):
    from jointid.report.html import Section, render_report

    page = render_report("t", "m", [Section("Summary", "summary", lists=(("What to trust", ["a < b"]), ("What not to trust", [])))])
    assert "<h3>What to trust</h3><ul><li>a &lt; b</li></ul>" in page and "What not to trust" not in page
    (tmp_path / "r.html").write_text(page)
    assert parse_report(tmp_path / "r.html").items["summary"] == ["a < b"]
