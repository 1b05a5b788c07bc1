import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_every_package_directory_is_declared():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    declared = set(config["packages"])
    mapping = {"wrinkle_vis": ROOT / "wrinkle_vis", "wrinkle_vis.widgets": ROOT / "widgets",
               "wrinkle_vis.datasets": ROOT / "datasets"}
    found = set()
    for name, folder in mapping.items():
        for init in folder.rglob("__init__.py"):
            rel = init.parent.relative_to(folder).parts
            found.add(".".join((name, *rel)) if rel else name)
        for data in folder.rglob("*.json"):  # data folders must be packages too
            rel = data.parent.relative_to(folder).parts
            found.add(".".join((name, *rel)) if rel else name)
    assert found <= declared, f"not in [tool.setuptools] packages: {sorted(found - declared)}"


def test_the_testing_extra_brings_pytest_pyvista_and_the_guide_names_it():
    """The plugin's users need pytest-pyvista's verify_image_cache: an extra of its own."""
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]
    names = {req.split(">")[0].split("=")[0].strip() for req in extras["testing"]}
    assert {"pytest", "pytest-pyvista"} <= names
    assert any("testing" in req for req in extras["test"])  # the suite's extra includes it
    guide = (ROOT / "docs" / "guide.md").read_text()
    section = guide[guide.index("## Image tests of your own"):]
    assert 'pip install "wrinkle-vis[testing]"' in section.split("\n## ")[0]
