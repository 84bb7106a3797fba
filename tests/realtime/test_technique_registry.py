"""The technique registry (scenes/model/technique_registry.py): builtins found through the entry-point
group like plugins, in the scene format's order; plugins beside them; broken plugins refused in one line
while the builtins keep working; a plugin's keys validated and stored only where it is chosen.

Plugins here are fake entry points (no package installed; tests/realtime/test_plugin.py installs the real
example), so no test needs OpenGL."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from realtime.engine import technique
from scenes.model import scene as scene_model
from scenes.model import technique_registry as reg
from scenes.storage.errors import InputError, MissingCapability, PluginDeclarationError, PluginLoadError, SceneError

ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Glow:
    strength: float = reg.param(1.0, reg.number(0, 4))


GLOW = reg.Declaration(effect="diffuse", name="glow", simulates=frozenset({"diffuse"}),
                       implementation="glow_plugin:Glow", table="glow", parameters=Glow,
                       reads=("realtime.glow.",), axes={"realtime.glow.strength": (0.5, 2.0)},
                       ladder=({"realtime.diffuse": "glow"},))


class FakeDist:
    def __init__(self, name: str) -> None:
        self.name = name


class FakeEntryPoint:
    """What the registry reads of an importlib.metadata.EntryPoint: name, dist.name, load()."""

    def __init__(self, name: str, dist: str, value) -> None:
        self.name, self.dist, self._value = name, FakeDist(dist), value

    def load(self):
        if isinstance(self._value, BaseException):
            raise self._value
        return self._value


@pytest.fixture
def plugins(monkeypatch):
    """install(*entry points): the builtins' real entry points plus these fakes, registry reloaded."""
    real = reg._entry_points

    def install(*fakes):
        monkeypatch.setattr(reg, "_entry_points", lambda: [*real(), *sorted(fakes, key=lambda e: e.name)])
        reg.registry.cache_clear()

    yield install
    monkeypatch.setattr(reg, "_entry_points", real)
    reg.registry.cache_clear()


def test_builtins_are_registered_in_the_scene_formats_order():
    assert [reg.choices(e) for e in reg.EFFECT_KEYS] == [
        ("sh", "irradiance_map", "lights", "prt", "wavelet_prt"), ("box", "prefiltered", "split_sum", "lights"),
        ("none", "shadow_maps", "prt", "vct", "wavelet_prt"), ("none", "prt", "vct", "wavelet_prt")]
    decls = reg.declarations()
    assert all(d.builtin and d.distribution == "iblcheck" for d in decls) and not reg.broken()
    assert {d.entry_point for d in decls} == {"sh", "irradiance_map", "box", "prefiltered", "split_sum", "lights",
                                                "shadow_maps", "prt", "vct", "wavelet_prt"}
    assert scene_model.SCHEMA["realtime"]["glossy"][1] == 'one of "box", "prefiltered", "split_sum", "lights"'


def test_declarations_import_without_opengl():
    code = ("import sys; from scenes.model import technique_registry as r; r.declarations(); "
            "import realtime.engine.technique; print('moderngl' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.stdout.strip() == "False"


def test_a_plugin_is_a_builtins_peer(plugins):
    plugins(FakeEntryPoint("glow", "glow-plugin", GLOW))
    d = reg.lookup("diffuse", "glow")
    assert (d.distribution, d.builtin, d.entry_point) == ("glow-plugin", False, "glow")
    assert reg.choices("diffuse")[-1] == "glow" and reg.declarations()[-1] is d  # after every builtin
    assert technique.owner_of("realtime.glow.strength") == ("diffuse", "glow")
    base = scene_model.load("builtin:sphere-diffuse")
    s = base.with_overrides({"realtime.diffuse": "glow", "realtime.glow.strength": 2})
    assert s.realtime.glow == Glow(2.0) and s.to_dict()["realtime"]["glow"] == {"strength": 2.0}
    # its table only where it is chosen: a builtin scene's content is unchanged by installing it
    assert "glow" not in base.to_dict()["realtime"]
    with pytest.raises(SceneError, match=r'realtime\.glow: this table is not used .* realtime\.diffuse = "glow"'):
        base.with_overrides({"realtime.glow.strength": 2})
    with pytest.raises(SceneError, match=r"realtime\.glow\.strength = 9: must be a number in \[0, 4\]"):
        base.with_overrides({"realtime.diffuse": "glow", "realtime.glow.strength": 9})


@pytest.mark.parametrize(("value", "says"), [
    (dataclasses.replace(GLOW, name="sh"), "realtime.diffuse = \"sh\" is already registered by 'iblcheck'"),
    (dataclasses.replace(GLOW, effect="shadows"), "effect = 'shadows': must be one of"),
    (dataclasses.replace(GLOW, simulates="diffuse"), "simulates must be a non-empty frozenset"),
    (dataclasses.replace(GLOW, axes={"realtime.glow.strength": 2.0}), "axes must map scene keys"),
    (dataclasses.replace(GLOW, table="lights"), "table realtime.lights is already declared by 'iblcheck'"),
    (dataclasses.replace(GLOW, implementation="glow_plugin.Glow"), 'must be "module:Class"'),
    (dataclasses.replace(GLOW, parameters=dataclass(frozen=True)(
        type("Bad", (), {"__annotations__": {"strength": "float"}, "strength": reg.param(9.0, reg.number(0, 4))}))),
     "realtime.glow.strength = 9.0: its default is outside its range"),
    (dataclasses.replace(GLOW, parameters=dataclass(frozen=True)(
        type("Bare", (), {"__annotations__": {"strength": "float"}, "strength": 1.0}))),
     "realtime.glow.strength has no check"),
    (dataclasses.replace(GLOW, timing_key="draw"), "the frame's own keys"),
    (dataclasses.replace(GLOW, extra_timing_keys=("total",)), "the frame's own keys"),
    (dataclasses.replace(GLOW, package="scenes.model", fragment_glsl=("glow.glsl",)),
     "does not hold: glow.glsl"),
    ("not a declaration", "must name a Declaration or a sequence of them"),
])
def test_a_bad_declaration_is_refused_in_one_line_and_the_builtins_still_work(plugins, value, says):
    plugins(FakeEntryPoint("glow", "glow-plugin", value))
    [broken] = reg.broken()
    assert isinstance(broken.error, PluginDeclarationError) and isinstance(broken.error, InputError)  # exit 2
    message = str(broken.error)
    assert "\n" not in message and message.startswith("technique plugin 'glow-plugin' (entry point "
                                                      "iblcheck.techniques:glow): ")
    assert says in message, message
    assert len(reg.declarations()) == 16 and reg.lookup("diffuse", "sh").builtin
    scene_model.load("builtin:sphere-diffuse").with_overrides({"realtime.diffuse": "irradiance_map"})
    with pytest.raises(PluginDeclarationError, match="glow-plugin"):  # choosing it is the error
        scene_model.load("builtin:sphere-diffuse").with_overrides({"realtime.diffuse": "glow"})


def _crashing_hook(*_args):
    raise AttributeError("'Realtime' object has no attribute 'glow_typo'")


@pytest.mark.parametrize("hook", ["validate", "describe"])
def test_a_plugin_hook_that_crashes_is_one_line_and_only_where_it_is_chosen(plugins, hook):
    """A plugin's bug in a hook: scenes without the plugin are untouched; the scene that chooses it gets one
    line naming the plugin and the hook (exit 3), not an internal error."""
    plugins(FakeEntryPoint("glow", "glow-plugin", dataclasses.replace(GLOW, **{hook: _crashing_hook})))
    builtin = scene_model.load("builtin:sphere-diffuse")
    assert technique.describe(builtin)["diffuse"] == "sh"
    with pytest.raises(PluginLoadError, match=rf"'glow-plugin' .*: its {hook} hook failed: AttributeError") as e:
        technique.describe(builtin.with_overrides({"realtime.diffuse": "glow"}))
    assert "\n" not in str(e.value)


def test_a_plugin_that_cannot_be_imported(plugins):
    plugins(FakeEntryPoint("glow", "glow-plugin", ModuleNotFoundError("No module named 'glow_gpu'")))
    [broken] = reg.broken()
    assert isinstance(broken.error, PluginLoadError) and isinstance(broken.error, MissingCapability)  # exit 3
    assert "cannot be imported: ModuleNotFoundError: No module named 'glow_gpu'" in str(broken.error)
    with pytest.raises(PluginLoadError):
        scene_model.load("builtin:sphere-diffuse").with_overrides({"realtime.diffuse": "glow"})
    # a choice no plugin has stays the plain enum error (negative control)
    with pytest.raises(SceneError, match='realtime.diffuse = \'nope\': must be one of "sh"'):
        scene_model.load("builtin:sphere-diffuse").with_overrides({"realtime.diffuse": "nope"})


def test_a_plugin_implementation_that_fails_to_import_names_the_plugin(plugins):
    plugins(FakeEntryPoint("glow", "glow-plugin", GLOW))
    with pytest.raises(PluginLoadError, match=r"'glow-plugin' .*cannot import its implementation 'glow_plugin:Glow'"):
        reg.lookup("diffuse", "glow").load()


def test_prt_settings_are_derived_once():
    from realtime.techniques.prt.settings import effective_settings

    base = scene_model.load("builtin:sphere-on-plane")
    plain = effective_settings(base.with_overrides({"realtime.diffuse": "prt", "realtime.prt.order": 3}))
    assert (plain.order, plain.rays, plain.bounces, plain.shadowed, plain.rays_reported) == (3, 1, 0, False, 0)
    full = effective_settings(base.with_overrides({"realtime.diffuse": "prt", "realtime.occlusion": "prt",
                                                   "realtime.interreflection": "prt", "realtime.prt.bounces": 2,
                                                   "realtime.prt.rays": 64}))
    assert (full.order, full.rays, full.bounces, full.shadowed, full.rays_reported) == (2, 64, 2, True, 64)
    assert reg.lookup("occlusion", "prt").effective_settings is effective_settings


@dataclass(frozen=True)
class GlowKeys:
    glow_gain: int = reg.param(1, reg.number(1, 8, integer=True))


def test_a_plugins_flat_key_is_read_only_where_it_is_chosen(plugins):
    plugins(FakeEntryPoint("glow", "glow-plugin", dataclasses.replace(GLOW, flat=GlowKeys)))
    base = scene_model.load("builtin:sphere-diffuse")
    s = base.with_overrides({"realtime.diffuse": "glow", "realtime.glow_gain": 3})
    assert s.realtime.glow_gain == 3 and s.to_dict()["realtime"]["glow_gain"] == 3
    assert "glow_gain" not in base.to_dict()["realtime"]
    with pytest.raises(AttributeError):
        base.realtime.glow_gain  # noqa: B018
    with pytest.raises(SceneError, match=r'realtime\.glow_gain: this key is not read .* realtime\.diffuse = "glow"'):
        base.with_overrides({"realtime.glow_gain": 3})
    # a name clash of flat keys with a builtin's is a bad declaration (negative control of the above)
    @dataclass(frozen=True)
    class Clash:
        sh_order: int = reg.param(2, reg.number(2, 4, integer=True))

    plugins(FakeEntryPoint("glow", "glow-plugin", dataclasses.replace(GLOW, flat=Clash)))
    assert "realtime.sh_order is already declared by 'iblcheck'" in str(reg.broken()[0].error)


def test_row_labels_come_from_the_declarations(plugins):
    """Tables name a row's techniques through each declaration's row_label: the builtins' as written by
    hand here, a plugin's through its own hook, a technique without one (or no longer registered) by name."""
    assert reg.row_label("diffuse", {"diffuse": "sh", "sh_order": 4, "sh_window": "hanning"}) == \
        "SH order 4 hanning window"
    assert reg.row_label("glossy", {"glossy": "box", "lod_bias": 1.0, "lod_mapping": "mcguire"}) == \
        "box bias 1 McGuire"
    assert reg.row_label("glossy", {"glossy": "prefiltered", "prefiltered": {"samples": 64, "bias": 1.0}}) == \
        "prefiltered 64 spl FIS bias 1"
    assert reg.row_label("diffuse", {"diffuse": "lights"}) == "lights"
    assert reg.row_label("diffuse", {"diffuse": "gone"}) == "gone"
    plugins(FakeEntryPoint("glow", "glow-plugin",
                           dataclasses.replace(GLOW, row_label=lambda t: f"glow x{t['glow']['strength']:g}")))
    assert reg.row_label("diffuse", {"diffuse": "glow", "glow": {"strength": 2.0}}) == "glow x2"
