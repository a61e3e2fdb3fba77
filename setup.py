"""The one part of the packaging that pyproject.toml cannot say: where the data goes.

The repository keeps its maps, sweep sets and sonar profiles in the top-level folder ``maps/``; an
installed nxtnav carries that folder as the package ``toolkit.data`` (every file under it, whatever
its name), so that `toolkit.world.bundled` finds it through ``importlib.resources`` in a wheel as in a
clone. Everything else (metadata, dependencies, the console script) is in pyproject.toml.
"""

from setuptools import find_namespace_packages, find_packages, setup

DATA_PACKAGE = "toolkit.data"
DATA_FOLDER = "maps"

# the data's sub-folders whose names Python could import are declared as packages too (setuptools
# warns about such folders otherwise); their files are the data package's either way
data_folders = [p for p in find_namespace_packages(DATA_FOLDER, exclude=["*__pycache__*"])
                if all(part.isidentifier() for part in p.split("."))]

setup(
    packages=[*find_packages(include=["toolkit", "toolkit.*", "planners", "planners.*", "localisation",
                                      "localisation.*"]),
              DATA_PACKAGE, *(f"{DATA_PACKAGE}.{p}" for p in data_folders)],
    package_dir={DATA_PACKAGE: DATA_FOLDER},
    package_data={DATA_PACKAGE: ["**/*"]},
    exclude_package_data={DATA_PACKAGE: ["__pycache__/*", "**/__pycache__/*"]},
)
