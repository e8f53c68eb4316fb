# Used by catkin (catkin_python_setup in CMakeLists.txt), not by pip: the venv installs the same sources through the
# repository's pyproject.toml. Do not call it directly.
from catkin_pkg.python_setup import generate_distutils_setup
from setuptools import find_packages, setup

setup(
    **generate_distutils_setup(
        packages=find_packages("src"),
        package_dir={"": "src"},
    )
)
