"""Where a STEP file's instance leaves a bracket open: the line a parser loses its place at (pure).

Why: one instance whose brackets do not close (``#12293= IFCPOLYLOOP((#8912,#891);``) makes ifcopenshell
read everything after it as that instance's arguments; it opens the file without an exception, having
lost most of the model, and its log names only the end markers (``Entity with name 'ENDSEC' not found``),
hundreds of lines too late. The converter then converted 5 of the Revit house's 60 components with exit
0. This scan finds the first instance of the DATA section whose ``;`` comes with a bracket still open,
outside quoted strings (STEP doubles a quote inside a string), an instance may span lines.
"""

from __future__ import annotations

from pathlib import Path

_DATA = b"DATA;"


def first_unclosed_line(path: Path) -> int | None:
    """The 1-based line of the first instance whose ``;`` comes with a bracket still open (or that closes
    a bracket it never opened); None when every instance of the DATA section balances."""
    depth = 0
    in_data = in_string = False
    start_line: int | None = None
    with Path(path).open("rb") as source:
        for number, line in enumerate(source, start=1):
            if not in_data:
                in_data = line.strip() == _DATA
                continue
            for byte in line:
                if in_string:
                    in_string = byte != 0x27  # ' ends it ('' is an end and a start again)
                elif byte == 0x27:
                    in_string = True
                elif byte == 0x28:  # (
                    if depth == 0:
                        start_line = number
                    depth += 1
                elif byte == 0x29:  # )
                    depth -= 1
                    if depth < 0:
                        return number
                elif byte == 0x3B and depth != 0:  # ; with a bracket open
                    return start_line
    return None
