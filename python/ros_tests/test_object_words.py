# SPDX-License-Identifier: Apache-2.0
"""hapticd_ros.object_words: hapticctl's words as the protocol's object descriptions, every malformed word named,
and moves. The references are the protocol's JSON written out by hand (docs/protocol.md, section 4) and the
client's own builders (hapticd_client.objects), an independent construction of the same dicts."""
from __future__ import annotations

import pytest

import hapticd_client as hc
from hapticd_ros.object_words import ObjectWordsError, moved, parse_object_words


def test_each_kind_gives_the_protocol_description():
    assert parse_object_words("plane normal=-1,0,0 offset=0.005 criterion=CE2") == hc.plane(
        normal=(-1, 0, 0), offset=0.005, criterion="CE2")
    assert parse_object_words("plane normal=0,0,1") == hc.plane(normal=(0, 0, 1))  # no gains: CE2, offset 0
    assert parse_object_words("plane normal=0,0,1 mode=bilateral K=500") == hc.plane(
        normal=(0, 0, 1), bilateral=True, K=500, B=0)
    assert parse_object_words("spring point=0,0,0.02 K=500 B=2") == hc.spring(point=(0, 0, 0.02), K=500, B=2)
    assert parse_object_words("spring constraint=line point=0,0,0 direction=0,0,1 criterion=CE1") == hc.spring(
        point=(0, 0, 0), constraint="line", direction=(0, 0, 1), criterion="CE1")
    assert parse_object_words("field center=0,0,0 radius=0.01 force=1,0,0") == hc.field(
        center=(0, 0, 0), radius=0.01, force=(1, 0, 0))
    assert parse_object_words("field center=0,0,0 radius=0.01 jacobian=-100,0,0,0,-100,0,0,0,-100 damping=2") == {
        "kind": "field", "center": [0.0, 0.0, 0.0], "radius": 0.01, "force": [0.0, 0.0, 0.0],
        "jacobian": [[-100.0, 0.0, 0.0], [0.0, -100.0, 0.0], [0.0, 0.0, -100.0]], "damping": 2.0}


@pytest.mark.parametrize("text, named", [
    ("", "an object kind is required"),
    ("box size=1", "object kind 'box' is unknown; accepted: plane, spring, field"),
    ("plane offset=0.1", "plane: normal= is required"),
    ("plane normal=1,0", "normal = '1,0' must be 3 comma-separated numbers"),
    ("plane normal=1,0,nan", "normal = 'nan' is not a finite number"),
    ("plane normal=1,0,0 offset=inf", "offset = 'inf' is not a finite number"),
    ("plane normal=1,0,0 offset", "'offset' is not key=value"),
    ("plane normal=1,0,0 radius=1", "plane: unknown key 'radius'; accepted: normal, offset, mode, criterion, K, B"),
    ("plane normal=1,0,0 normal=1,0,0", "plane: normal= given twice"),
    ("plane normal=1,0,0 mode=sticky", "plane: mode = 'sticky'; accepted: unilateral, bilateral"),
    ("plane normal=1,0,0 K=1 criterion=CE2", "plane: give either criterion= or K=/B=, not both"),
    ("plane normal=1,0,0 B=1", "plane: B= needs K= (N/m)"),
    ("spring point=0,0,0", "spring: gains are required"),
    ("spring constraint=ring point=0,0,0 K=1", "spring: constraint = 'ring'; accepted: point, line, plane"),
    ("spring point=0,0,0 direction=0,0,1 K=1", "spring: direction= is not used by constraint=point"),
    ("spring constraint=line point=0,0,0 K=1", "spring: direction= is required"),
    ("field center=0,0,0", "field: radius= is required"),
    ("field center=0,0,0 radius=1 jacobian=1,2,3", "jacobian = '1,2,3' must be 9 comma-separated numbers"),
])
def test_a_malformed_description_is_refused_naming_the_word(text, named):
    with pytest.raises(ObjectWordsError) as e:
        parse_object_words(text)
    assert named in str(e.value)


def test_a_move_places_the_object_at_the_point_and_changes_nothing_else():
    plane = parse_object_words("plane normal=0.6,0.8,0 offset=0.01 K=500 B=2")
    at = moved(plane, (0.01, 0.02, 0.5))
    assert at["offset"] == pytest.approx(0.6 * 0.01 + 0.8 * 0.02, abs=1e-18)  # n . p: the surface through p
    assert {k: v for k, v in at.items() if k != "offset"} == {k: v for k, v in plane.items() if k != "offset"}
    assert plane["offset"] == 0.01  # the original is not changed
    assert moved(parse_object_words("spring point=0,0,0 K=5 B=1"), (1, 2, 3))["point"] == [1.0, 2.0, 3.0]
    assert moved(parse_object_words("field center=0,0,0 radius=1"), (1, 2, 3))["center"] == [1.0, 2.0, 3.0]
    with pytest.raises(ObjectWordsError, match="expected 3 finite numbers"):
        moved(plane, (0.0, float("nan"), 0.0))
