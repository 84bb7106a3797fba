"""Every key of the scene schema refuses out-of-range and wrong-type values, naming the key."""

from __future__ import annotations

import pytest

from scenes import SceneError
from scenes.scene import SCHEMA, from_dict


def bad_values(text: str) -> list:
    if text.startswith(("a number", "an integer")):
        return [-1e30, 1e30, "7", float("nan")]
    if text.startswith("a list of 3"):
        return [[1e30, 0.0, 0.0], [0.0, 0.0], "x"]
    if text.startswith("a power of two"):
        return [3, 0, 1 << 20, 2.0]
    if text.startswith("one of"):
        return ["no-such-choice", 1]
    if text == "true or false":
        return [1, "yes"]
    if text == "a non-empty string":
        return ["", 3]
    raise AssertionError(f"unclassified check: {text}")


def tree_with(section: str, key: str, value) -> tuple[dict, str]:
    tree: dict = {"objects": [{"shape": "sphere", "material": {"type": "blend"}}]}
    if section == "object":
        tree["objects"][0][key] = value
        return tree, f"objects[0].{key}"
    if section == "material":
        tree["objects"][0]["material"][key] = value
        return tree, f"objects[0].material.{key}"
    tree[section] = {key: value}
    return tree, f"{section}.{key}"


CASES = [(section, key, v) for section, keys in SCHEMA.items() for key, (_, text) in keys.items()
         for v in bad_values(text)]


@pytest.mark.parametrize(("section", "key", "value"), CASES, ids=[f"{s}.{k}={v!r}" for s, k, v in CASES])
def test_every_bad_value_is_refused_with_its_key(tmp_path, section, key, value):
    tree, name = tree_with(section, key, value)
    with pytest.raises(SceneError) as err:
        from_dict(tree, "every.toml", tmp_path)
    msg = str(err.value)
    assert msg.startswith("every.toml: ")
    assert name in msg or name.replace("[0]", ".0") in msg or key in msg, msg
