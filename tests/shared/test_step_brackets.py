"""The first STEP instance whose brackets do not close, found where a parser loses its place."""

from __future__ import annotations

from pathlib import Path

from bimbot.shared.step_brackets import first_unclosed_line

HEAD = "ISO-10303-21;\nHEADER;\nFILE_NAME('a (b','',(''),(''),'','','');\nENDSEC;\nDATA;\n"
TAIL = "ENDSEC;\nEND-ISO-10303-21;\n"


def _file(tmp_path: Path, data: str) -> Path:
    path = tmp_path / "m.ifc"
    path.write_text(HEAD + data + TAIL, encoding="utf-8")
    return path


def test_a_sound_file_balances_strings_with_brackets_and_wrapped_instances_included(tmp_path: Path) -> None:
    data = "#1=IFCDIRECTION((0.,0.,1.));\n#2=IFCWALL('x','it''s (odd',$,\n(#1));\n#3=IFCOWNERHISTORY($);\n"
    assert first_unclosed_line(_file(tmp_path, data)) is None


def test_the_instance_left_open_is_named_by_its_line(tmp_path: Path) -> None:
    data = "#1=IFCDIRECTION((0.,0.,1.));\n#2=IFCPOLYLOOP((#8912,#891);\n#3=IFCDIRECTION((1.,0.,0.));\n"
    assert first_unclosed_line(_file(tmp_path, data)) == 7
    closed_too_often = "#1=IFCDIRECTION((0.,0.,1.)));\n"
    assert first_unclosed_line(_file(tmp_path, closed_too_often)) == 6
