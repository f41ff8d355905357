"""symgen.scene.parsed: a TOML text parsed once, recalled from a sealed verdict after; only a
parse JSON holds exactly is remembered, and a text that does not parse never is."""

from __future__ import annotations

import tomllib

import pytest

from symgen.scene import parsed


@pytest.fixture
def calls(tmp_path, monkeypatch):
    monkeypatch.setenv("SYMGEN_CACHE_DIR", str(tmp_path / "cache"))
    seen: list[str] = []
    real = tomllib.loads

    def loads(text: str, **kw):
        seen.append(text)
        return real(text, **kw)

    monkeypatch.setattr(tomllib, "loads", loads)
    return seen


TEXT = """
[scene]
name = "x"
big = 123456789012345678901234567890
[[bodies]]
zeta = 1
alpha = 2
[[bodies]]
length = 1.0
lambda = 1e10
neg = -0.0
flags = [true, false, 3, 2.5, "s"]
nested = { a = { b = [[1], [2.0]] } }
"""


def test_a_text_is_parsed_once_and_recalled_equal(calls):
    first = parsed.loads(TEXT)
    again = parsed.loads(TEXT)
    assert calls == [TEXT]  # the second from the cache
    assert again == first == tomllib.loads(TEXT)
    # in the text's order (a scene's outputs are columns in the order given)
    assert list(again) == ["scene", "bodies"] and list(again["scene"]) == ["name", "big"]
    assert list(again["bodies"][0]) == ["zeta", "alpha"]
    # the same types, not only equal values (1.0 stays a float, 3 an int, True a bool)
    body = again["bodies"][1]
    assert type(body["length"]) is float and type(body["flags"][2]) is int and body["flags"][0] is True
    assert str(body["neg"]) == "-0.0" and again["scene"]["big"] == 123456789012345678901234567890


@pytest.mark.parametrize("value", ["1979-05-27T07:32:00Z", "inf", "nan", "07:32:00"])
def test_a_parse_json_does_not_hold_is_not_remembered(calls, value):
    text = f"v = {value}\n"
    a, b = parsed.loads(text), parsed.loads(text)
    assert calls == [text, text]
    assert type(a["v"]) is type(b["v"])


def test_a_text_that_does_not_parse_raises_each_time(calls):
    for _ in range(2):
        with pytest.raises(tomllib.TOMLDecodeError):
            parsed.loads("v = [1,")
    assert len(calls) == 2


def test_a_recalled_parse_is_checked_like_a_parse(tmp_path, calls):
    """The loader checks what it recalls as what it parses: a bad scene fails the same way."""
    from symgen.errors import SceneError
    from symgen.scene import load_scene

    bad = tmp_path / "bad.toml"
    bad.write_text('[scene]\nname = "x"\nunknown_key = 1\n')
    messages = []
    for _ in range(2):
        with pytest.raises(SceneError) as err:
            load_scene(str(bad), [])
        messages.append(str(err.value))
    assert messages[0] == messages[1] and len(calls) == 1
