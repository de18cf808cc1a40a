"""ROS 2 names (issue 46, class 9): what a user types as an arm namespace or a topic is checked
against ROS 2's rules before it reaches a bag reader or the middleware, in one line naming the
rule; the names the dVRK uses pass unchanged."""

from __future__ import annotations

import pytest

from psmforce.io.bags import BagError
from psmforce.io.bags.names import MAX_NAME_CHARS, check_namespace, check_ros_name
from psmforce.io.bags.reading import resolve_topics
from psmforce.live.node import output_topics


@pytest.mark.parametrize("name, full", [
    ("/PSM1/measured_js", "/PSM1/measured_js"), ("hex10/measured_cf", "/hex10/measured_cf"),
    ("/_private/x_1", "/_private/x_1"), ("/a/b/c/d", "/a/b/c/d")])
def test_the_names_ros_2_accepts_pass_as_absolute_names(name, full):
    assert check_ros_name(name, "topic") == full


@pytest.mark.parametrize("name, rule", [
    ("PS M1", "character ' '"), ("PSM\n1", "character '\\\\n'"), ("1PSM", "starts with a digit"),
    ("/PSM1/9js", "token '9js' starts with a digit"), ("PSM-1", "character '-'"),
    ("a//b", "empty token"), ("/a/", "must not end with '/'"), ("~/x", "character '~'"),
    ("{node}/x", "character '{'"), ("PSMé", "character 'é'"), ("", "non-empty"),
    (None, "non-empty"), ("a" * MAX_NAME_CHARS, "at most")])
def test_a_name_outside_the_rules_is_refused_naming_the_rule(name, rule):
    with pytest.raises(ValueError, match=rule):
        check_ros_name(name, "topic")


def test_every_way_in_checks_the_name_the_same_way():
    assert check_namespace("/PSM1/") == "PSM1" and output_topics("PSM2")["hex10"] == \
        "/PSM2/tool_force/hex10"
    with pytest.raises(ValueError, match="arm 'PS M1'"):
        output_topics("PS M1")  # the live node's outputs
    with pytest.raises(BagError, match="arm 'PS M1'"):
        resolve_topics("PS M1", {})  # convert, replay, serve's inputs
    with pytest.raises(BagError, match="topic for stream 'js' 'a b'"):
        resolve_topics("PSM1", {"js": "a b"})
    with pytest.raises(ValueError, match="namespace such as 'PSM1'"):
        check_namespace("///")


@pytest.mark.parametrize("argv", [["serve", "x.pt", "--arm", "PS M1"],
                                  ["replay", "bag", "x.pt", "--out", "o.mcap", "--topic-ati",
                                   "a-b"],
                                  ["convert", "bag", "--out", "o.csv", "--topic-js", "a//b"]])
def test_the_command_line_refuses_a_name_before_any_work(argv, capsys, tmp_path, monkeypatch):
    from psmforce.cli.main import main
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as stop:
        main(argv)
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert stop.value.code == 2 and ("not a ROS 2 name" in err or "empty token" in err)
    assert list(tmp_path.iterdir()) == []
