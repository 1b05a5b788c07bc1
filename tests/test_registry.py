from dataclasses import dataclass
from importlib.metadata import EntryPoint

import numpy as np
import pytest
from meshes import grid

import wrinkle_vis as wv
from wrinkle_vis.core import registry


def test_builtin_types_are_registered():
    types = wv.muscle_types()
    assert types["linear"] is wv.LinearMuscle and types["sheet"] is wv.SheetMuscle


def test_builtin_types_are_declared_as_entry_points_too():
    from importlib.metadata import entry_points

    names = {ep.name: ep.value for ep in entry_points(group="wrinkle_vis.muscles")}
    assert names["linear"] == "wrinkle_vis.core.muscles:LinearMuscle"
    assert names["sheet"] == "wrinkle_vis.core.muscles:SheetMuscle"


def test_pyproject_declares_every_builtin_type_as_an_entry_point():
    """The source of the installed metadata (checked above once installed): each built-in
    type, in its own module, is registered by its entry point, not by a list in the core.
    """
    import importlib
    import tomllib
    from pathlib import Path

    config = tomllib.loads((Path(wv.__file__).parents[1] / "pyproject.toml").read_text())
    declared = config["project"]["entry-points"]["wrinkle_vis.muscles"]
    for name, value in declared.items():
        module, _, attr = value.partition(":")
        cls = getattr(importlib.import_module(module), attr)
        assert cls.type_name == name and wv.get_muscle_type(name) is cls
    builtin = {n for n, c in wv.muscle_types().items() if c.__module__.startswith("wrinkle_vis.")}
    assert builtin <= set(declared) and {"linear", "sheet", "sphincter"} <= set(declared)


def test_example_plugin_is_discovered_through_its_entry_point_and_works_end_to_end():
    ring_cls = wv.muscle_types()["ring"]
    assert ring_cls.__module__ == "wrinkle_vis_ring"
    ring = wv.muscle_from_dict({"type": "ring", "name": "orbicularis", "center": [0, 0, 0],
                                "axis": [0, 0, 1], "radius": 20.0, "k0": 1.0})
    assert isinstance(ring, ring_cls)
    assert wv.muscle_from_dict(ring.to_dict()) == ring
    face = wv.FaceModel(grid(41, 41, 60.0), None, [ring])
    state = face.evaluate({"orbicularis": 1.0})
    w = state.fields["orbicularis"]["W"]
    assert np.isfinite(w).sum() > 0 and np.nanmax(np.abs(w)) > 0
    assert np.isnan(w[np.linalg.norm(face.skin.points[:, :2], axis=1) > 21]).all()


@pytest.fixture
def clean_registry():
    saved = dict(registry._REGISTRY)
    yield
    registry._REGISTRY.clear()
    registry._REGISTRY.update(saved)


def _toy_type(type_name):
    @dataclass(frozen=True)
    class Toy(wv.SheetMuscle):
        pass

    Toy.type_name = type_name
    return Toy


def test_decorator_registers_and_duplicates_need_override(clean_registry):
    toy = wv.register_muscle_type(_toy_type("toy"))
    assert wv.muscle_types()["toy"] is toy
    assert wv.register_muscle_type(toy) is toy  # the same class again is a no-op
    other = _toy_type("toy")
    with pytest.raises(ValueError, match="already registered.*override=True"):
        wv.register_muscle_type(other)
    wv.register_muscle_type(other, override=True)
    assert wv.get_muscle_type("toy") is other
    with pytest.raises(ValueError, match="already registered"):
        wv.register_muscle_type(_toy_type("linear"))


def test_decorator_with_a_name_and_non_muscles(clean_registry):
    @wv.register_muscle_type(name="named")
    @dataclass(frozen=True)
    class Named(wv.LinearMuscle):
        pass

    assert wv.get_muscle_type("named") is Named and Named.type_name == "named"
    with pytest.raises(TypeError, match="not a subclass"):
        wv.register_muscle_type(dict)


def test_unknown_type_lists_installed_ones():
    with pytest.raises(wv.UnknownMuscleTypeError, match="installed types: .*linear.*sheet"):
        wv.get_muscle_type("spiral")
    with pytest.raises(wv.UnknownMuscleTypeError):
        wv.muscle_from_dict({"type": "spiral", "name": "x"})
    with pytest.raises(ValueError, match="has no 'type'"):
        wv.muscle_from_dict({"name": "x"})


def test_broken_plugin_is_skipped_with_a_warning_that_names_it(clean_registry):
    ep = EntryPoint(name="broken", value="wrinkle_vis_no_such_module:Muscle",
                    group="wrinkle_vis.muscles")
    with pytest.warns(wv.MusclePluginWarning, match="'broken'.*wrinkle_vis_no_such_module"):
        assert registry.load_entry_point(ep) is None
    assert "broken" not in wv.muscle_types()


def test_a_broken_plugins_warning_is_one_line_without_a_source_line(clean_registry):
    """Python shows a warning as ``file:line: Category: message`` plus the source line of
    ``file:line``; about a plug-in that line is the toolkit's, noise on every command.
    """
    import warnings

    ep = EntryPoint(name="broken", value="wrinkle_vis_no_such_module:Muscle",
                    group="wrinkle_vis.muscles")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        registry.load_entry_point(ep)
    (w,) = caught
    shown = warnings.formatwarning(w.message, w.category, w.filename, w.lineno, w.line)
    assert shown.count("\n") == 1 and "MusclePluginWarning: wrinkle-vis skipped" in shown
    assert "<plug-in broken>" in shown


def test_entry_point_loading_is_lazy_and_runs_once(monkeypatch, clean_registry):
    calls = []
    real = registry.entry_points

    def counting(**kw):
        calls.append(kw)
        return real(**kw)

    monkeypatch.setattr(registry, "entry_points", counting)
    monkeypatch.setattr(registry, "_ENTRY_POINTS_LOADED", False)
    wv.muscle_types()
    wv.muscle_types()
    assert calls == [{"group": "wrinkle_vis.muscles"}]
