"""Bounded reading of documents lutbake did not write (lutbake/io/documents.py)."""

import json

import pytest

from lutbake.io.documents import MAX_NESTING, load_json, load_toml, read_text


def test_json_within_the_bound_parses_as_json_does():
    doc = {"a": [1, {"b": [2.5, None, "x]}[{"]}], "c": '\\"{'}
    assert load_json(json.dumps(doc), "header") == doc


@pytest.mark.parametrize("depth", [MAX_NESTING + 1, 100_000])
def test_json_nested_past_the_bound_is_one_value_error(depth):
    # 100,000 levels: json.loads alone raises RecursionError here
    with pytest.raises(ValueError, match=f"^header nests {depth} levels deep: at most {MAX_NESTING}"):
        load_json("[" * depth + "]" * depth, "header")


def test_json_at_the_bound_parses():
    text = "[" * MAX_NESTING + "]" * MAX_NESTING
    assert load_json(text, "header") is not None


def test_brackets_inside_json_strings_do_not_count():
    text = json.dumps({"k": "[" * 1000})
    assert load_json(text, "header") == {"k": "[" * 1000}


def test_json_that_is_not_json_names_what_it_is():
    with pytest.raises(ValueError, match=r"^journal is not JSON"):
        load_json("{'a': 1}", "journal")


def test_toml_nested_arrays_past_the_bound_are_refused():
    text = "x = " + "[" * 5000 + "]" * 5000 + "\n"
    with pytest.raises(ValueError, match="^scene.toml nests 5000 levels deep"):
        load_toml(text, "scene.toml")


def test_toml_brackets_in_strings_and_comments_do_not_count():
    deep = "[" * 100
    text = (
        f"a = \"{deep}\"\nb = '{deep}'\n# {deep}\nc = \"\"\"\n{deep}\n\"\"\"\nd = '''{deep}'''\n"
        "[t]\ne = [[1, 2], {f = 3}]\n"
    )
    doc = load_toml(text, "scene.toml")
    assert doc["a"] == doc["b"] == deep and doc["t"]["e"] == [[1, 2], {"f": 3}]


def test_invalid_toml_is_one_line_naming_the_file():
    with pytest.raises(ValueError, match=r"^scene.toml: invalid TOML: ") as info:
        load_toml("a = = 1", "scene.toml")
    assert "\n" not in str(info.value)


def test_read_text_refuses_past_its_size_before_reading_it_whole(tmp_path):
    path = tmp_path / "big.json"
    path.write_bytes(b" " * 1001)
    with pytest.raises(ValueError, match=r"^manifest '.*big.json' is over 1,000 bytes"):
        read_text(path, "manifest", 1000)
    assert read_text(path, "manifest", 1001) == " " * 1001


def test_read_text_refuses_bytes_that_are_not_utf8(tmp_path):
    path = tmp_path / "x.json"
    path.write_bytes(b'{"a": "\xff"}')
    with pytest.raises(ValueError, match="is not UTF-8 text"):
        read_text(path, "journal", 100)
