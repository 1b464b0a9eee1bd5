"""The ROS 2 bag reader's kept YAML parses (io.rosbag._cached_yaml_class): the same data as
ruamel.yaml's safe loader, a fresh copy each time, the same errors; rosbags' own ``YAML`` is
back in place after a bag is opened."""

from __future__ import annotations

import pytest

pytest.importorskip("rosbags")

from ruamel.yaml import YAML  # noqa: E402
from ruamel.yaml.error import YAMLError  # noqa: E402

from usvid.io.rosbag import _cached_yaml, _cached_yaml_class  # noqa: E402

TEXTS = ["a: 1\nb: [1, 2.5, x]\n", "- history: 3\n  depth: 0\n  deadline: {sec: 1, nsec: 0}\n",
         "rosbag2_bagfile_information:\n  version: 5\n  topics_with_message_count: []\n", "",
         "t: 2026-11-24\n"]


@pytest.mark.parametrize("text", TEXTS)
def test_same_data_fresh_copies(text):
    cls = _cached_yaml_class()
    want = YAML(typ="safe").load(text)
    first = cls(typ="safe").load(text)
    assert first == want and type(first) is type(want)
    if isinstance(first, dict):
        first["added"] = 1
    assert cls(typ="safe").load(text) == want  # not the object handed out before


@pytest.mark.parametrize("text", ["a: [1, 2", "a: b: c", "{"])
def test_same_errors(text):
    with pytest.raises(YAMLError) as want:
        YAML(typ="safe").load(text)
    for _ in range(2):
        with pytest.raises(YAMLError) as got:
            _cached_yaml_class()(typ="safe").load(text)
        assert str(got.value) == str(want.value)


def test_other_uses_are_ruamels():
    y = _cached_yaml_class()(typ="rt")
    assert y.load("a: 1 # c\n")["a"] == 1
    assert _cached_yaml_class()(typ="safe").typ == YAML(typ="safe").typ


def test_rosbags_yaml_put_back():
    from rosbags.rosbag2 import metadata, reader

    before = reader.YAML, metadata.YAML
    with _cached_yaml(_cached_yaml_class()):
        assert reader.YAML is metadata.YAML is _cached_yaml_class()
    assert (reader.YAML, metadata.YAML) == before
