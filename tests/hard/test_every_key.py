"""Every key of the scene schema refuses out-of-range and wrong-type values, naming the key."""

from __future__ import annotations

import pytest

from scenes import SceneError
from scenes.model.scene import MATERIAL_KEYS, SCHEMA, from_dict


def bad_values(text: str) -> list:
    if text.startswith(("a number", "an integer")):
        return [-1e30, 1e30, "7", float("nan")]
    if text.startswith("a list of 3"):
        return [[1e30, 0.0, 0.0], [0.0, 0.0], "x"]
    if text.startswith("a power of two"):
        return [3, 0, 1 << 20, 2.0]
    if text.startswith("one of"):
        return ["no-such-choice", 1]
    if text.startswith("true or false"):  # also `or "recipe"` (the split sum's recipe-default keys)
        return [1, "yes"]
    if text == "a non-empty string":
        return ["", 3]
    raise AssertionError(f"unclassified check: {text}")


def tree_with(section: str, key: str, value) -> tuple[dict, str]:
    """A minimal scene tree with one bad value, and the dotted name the message must carry."""
    tree: dict = {"objects": [{"shape": "sphere", "material": {"type": "blend"}}]}
    if section == "object":
        tree["objects"][0][key] = value
        return tree, f"objects[0].{key}"
    if section == "material":
        if key in MATERIAL_KEYS["pbr"] - MATERIAL_KEYS["blend"]:  # a glTF key: on a material of its own type
            tree["objects"][0]["material"]["type"] = "pbr"
            tree["realtime"] = {"glossy": "split_sum"}
        tree["objects"][0]["material"][key] = value
        return tree, f"objects[0].material.{key}"
    node = tree
    for part in section.split("."):  # nested tables, e.g. realtime.prefiltered
        node = node.setdefault(part, {})
    node[key] = value
    return tree, f"{section}.{key}"


CASES = [(section, key, v) for section, keys in SCHEMA.items() for key, (_, text) in keys.items()
         for v in bad_values(text)]


@pytest.mark.parametrize(("section", "key", "value"), CASES, ids=[f"{s}.{k}={v!r}" for s, k, v in CASES])
def test_every_bad_value_is_refused_with_its_key(tmp_path, section, key, value):
    tree, name = tree_with(section, key, value)
    with pytest.raises(SceneError) as err:
        from_dict(tree, "every.toml", tmp_path)
    msg = str(err.value)
    # the exact `section.key = value` of docs/contract.md section 5, then what is allowed: a bare key name
    # (`scale`, `type`, `map`) or a message without its section would not match
    _, text = SCHEMA[section][key]
    assert msg == f"every.toml: {name} = {value!r}: must be {text}", msg
