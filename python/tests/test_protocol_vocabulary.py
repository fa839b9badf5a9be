# SPDX-License-Identifier: Apache-2.0
"""The Python packages' copies of the protocol's vocabulary agree with the C++ definitions they mirror: the
error codes (hapticd::client::ErrorCode, src/client/error_code.cpp), the state's fault numbers and names
(hapticd::StateFault, include/hapticd/state_layout.hpp) and the criterion names (include/hapticopt/criterion.hpp).
Each test reads the C++ source, so a code, number or name added or changed on one side only fails here."""
from __future__ import annotations

import re

import hapticd_client as hc
import hapticopt as ho
from conftest import REPOSITORY


def cpp_error_codes():
    """(enumerator, wire string) of error_code.cpp's table, in its order."""
    text = (REPOSITORY / "src" / "client" / "error_code.cpp").read_text()
    return re.findall(r'\{\s*ErrorCode::(\w+),\s*"([a-z_]+)"\}', text)


def cpp_enumerators(header: str, enum: str):
    """The enumerators of `enum class <enum> ... { ... };` in `header`, with their explicit values if any."""
    text = (REPOSITORY / header).read_text()
    body = re.search(r"enum class " + enum + r"\b[^{]*\{(.*?)\};", text, re.S).group(1)
    body = re.sub(r"//[^\n]*", "", body)
    return [tuple(part.strip() for part in item.split("=")) for item in body.split(",") if item.strip()]


def test_error_codes_are_the_cpp_enums():
    table = cpp_error_codes()
    enumerators = [e[0] for e in cpp_enumerators("include/hapticd/client.hpp", "ErrorCode")]
    assert len(enumerators) >= 19
    # The C++ table names every enumerator exactly once, and Python has exactly its strings.
    assert sorted(name for name, _ in table) == sorted(enumerators)
    assert len({code for _, code in table}) == len(table)
    assert sorted(hc.ERROR_CODES) == sorted(code for _, code in table)


def test_state_faults_are_the_cpp_enum():
    header = "include/hapticd/state_layout.hpp"
    values = {name: int(value) for name, value in cpp_enumerators(header, "StateFault")}
    assert values == {"None": 0, "Device": 1, "NonFinite": 2, "Watchdog": 3, "FatalSignal": 4, "Terminate": 5}
    snake = {re.sub(r"(?<!^)([A-Z])", r"_\1", name).upper(): value for name, value in values.items()}
    assert {f.name: f.value for f in hc.StateFault} == snake
    text = (REPOSITORY / header).read_text()
    names = dict(re.findall(r'case StateFault::(\w+):\s*return "([a-z_-]+)";', text))
    assert {values[name]: wire for name, wire in names.items()} == {int(k): v for k, v in hc.FAULT_NAMES.items()}
    assert hc.FAULT_FATAL_SIGNAL == values["FatalSignal"] and hc.FAULT_TERMINATE == values["Terminate"]


def test_wire_names_have_one_style():
    """Fault names and error codes on the wire are lower-case words joined by '_' (docs/architecture.md, glossary)."""
    header = (REPOSITORY / "include/hapticd/state_layout.hpp").read_text()
    faults = re.findall(r'case StateFault::\w+:\s*return "([^"]+)";', header)
    codes = [code for _, code in re.findall(r'\{\s*ErrorCode::(\w+),\s*"([^"]+)"\}',
                                             (REPOSITORY / "src/client/error_code.cpp").read_text())]
    assert len(faults) == 6 and len(codes) >= 19
    for wire in faults + codes:
        assert re.fullmatch(r"[a-z]+(_[a-z]+)*", wire), wire


def test_criterion_names_are_the_cpp_ones():
    text = (REPOSITORY / "include" / "hapticopt" / "criterion.hpp").read_text()
    step = dict(re.findall(r'case Criterion::(\w+):\s*return "([^"]+)";', text))
    order = re.search(r"kAllCriteria = \{(.*?)\};", text, re.S).group(1)
    assert ho.STEP_CRITERIA == tuple(step[c] for c in re.findall(r"Criterion::(\w+)", order))
    collision = dict(re.findall(r'case ImpulseCriterion::(\w+):\s*return "([^"]+)";', text))
    order = re.search(r"kAllImpulseCriteria = \{(.*?)\};", text, re.S).group(1)
    assert ho.COLLISION_CRITERIA == tuple(collision[c] for c in re.findall(r"ImpulseCriterion::(\w+)", order))
    assert ho.CRITERIA_WITH_SURFACE == ("CE0", "CE1", "CE2", "OV", "CI0", "CI1", "CI2")
