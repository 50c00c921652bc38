"""The cells of an Office Open XML spreadsheet (.xlsx), read with the standard library.

A workbook is a zip of XML parts: ``xl/workbook.xml`` names the sheets and points (through
``xl/_rels/workbook.xml.rels``) at one ``xl/worksheets/sheetN.xml`` each; a cell holds a
number, an index into ``xl/sharedStrings.xml`` (``t="s"``), an inline string or a formula's
cached value. Recorded gait comes as such workbooks (Winter's appendix is one), and reading
the values needs none of a spreadsheet package's styling, formulas or writing: this module
reads values only, so the product stays on casadi, numpy and matplotlib.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

from planner.errors import DefinitionError

_MAIN = "{http://schemas.openxmlformats.org/spreadsheetml/2006/main}"
_RELATION = "{http://schemas.openxmlformats.org/officeDocument/2006/relationships}id"
_CELL = re.compile(r"([A-Z]+)(\d+)$")

#: A sheet: {(row, column): value}, rows and columns from 1 (A = 1), values str or float.
Cells = dict[tuple[int, int], "str | float"]


def column_number(letters: str) -> int:
    """'A' -> 1, 'Z' -> 26, 'AA' -> 27: a column's number from its letters."""
    number = 0
    for letter in letters:
        number = number * 26 + ord(letter) - ord("A") + 1
    return number


def read_workbook(path: str | Path) -> dict[str, Cells]:
    """Every sheet of the workbook at ``path`` by name, as {(row, column): value} (empty
    cells left out; numbers as float, text stripped of surrounding blanks).

    Raises DefinitionError naming the file when it is not a readable .xlsx workbook."""
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as archive:
            parts = {
                name: archive.read(name)
                for name in archive.namelist()
                if name.startswith("xl/") and name.endswith((".xml", ".rels"))
            }
    except (OSError, zipfile.BadZipFile) as error:
        raise DefinitionError(
            f"`path`: {str(path)!r} is not a readable .xlsx workbook ({error}); save the sheet "
            "as .xlsx or export it to the CSV layout of problems.human.recording"
        ) from error
    try:
        strings = _shared_strings(parts.get("xl/sharedStrings.xml"))
        targets = {
            rel.get("Id"): rel.get("Target")
            for rel in ET.fromstring(parts["xl/_rels/workbook.xml.rels"])
        }
        book = ET.fromstring(parts["xl/workbook.xml"])
        sheets = {}
        for sheet in book.iter(f"{_MAIN}sheet"):
            target = targets[sheet.get(_RELATION)].lstrip("/")
            target = target if target.startswith("xl/") else f"xl/{target}"
            sheets[sheet.get("name")] = _cells(ET.fromstring(parts[target]), strings)
    except (KeyError, ET.ParseError, ValueError) as error:
        raise DefinitionError(
            f"`path`: {str(path)!r} is a zip but not a workbook this reader knows ({error!r})"
        ) from error
    return sheets


def _shared_strings(part: bytes | None) -> list[str]:
    if part is None:
        return []
    return [_text(item) for item in ET.fromstring(part).iter(f"{_MAIN}si")]


def _text(element) -> str:
    return "".join(node.text or "" for node in element.iter(f"{_MAIN}t"))


def _cells(sheet, strings: list[str]) -> Cells:
    cells: Cells = {}
    for cell in sheet.iter(f"{_MAIN}c"):
        match = _CELL.match(cell.get("r", ""))
        if match is None:
            continue
        kind, value = cell.get("t"), cell.find(f"{_MAIN}v")
        if kind == "inlineStr":
            text = _text(cell)
        elif value is None or value.text is None:
            continue
        elif kind == "s":
            text = strings[int(value.text)]
        elif kind in ("str", "e", "b"):
            text = value.text
        else:
            cells[(int(match[2]), column_number(match[1]))] = float(value.text)
            continue
        text = text.strip()
        if text:
            cells[(int(match[2]), column_number(match[1]))] = _number_or_text(text)
    return cells


def _number_or_text(text: str) -> str | float:
    """Numbers typed as text (Winter's sheets hold some, with a Unicode minus) as float."""
    try:
        return float(text.replace("\u2212", "-"))
    except ValueError:
        return text
