"""rockdove.resources: the data folders ship inside the package and are found through importlib.resources."""

import tomllib
from pathlib import Path

import pytest

from rockdove import resources
from rockdove.errors import ResourceMissing

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("name", ["materials/thinfilm.mtlx", "materials/glsl/thinfilm.frag",
                                  "schemas/plugInfo.json", "schemas/config.schema.json",
                                  "assets/pigeon/measured.toml"])
def test_every_data_file_the_code_reads_resolves_to_a_readable_file(name):
    assert resources.path(name).is_file()
    assert resources.path(name).stat().st_size > 0


def test_a_missing_resource_names_itself():
    with pytest.raises(ResourceMissing, match="materials/no-such.mtlx"):
        resources.path("materials/no-such.mtlx")
    with pytest.raises(ValueError, match="'textures'"):
        resources.folder("textures")


def test_pyproject_lists_every_subpackage_so_the_wheel_carries_it():
    listed = set(tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    on_disk = {"rockdove." + p.parent.name for p in (REPO / "pipeline" / "rockdove").glob("*/__init__.py")} | {"rockdove"}
    assert on_disk <= listed, f"add to pyproject.toml [tool.setuptools] packages: {sorted(on_disk - listed)}"
    assert {f"rockdove.{d}" for d in resources.FOLDERS} <= listed
