# Installed by catkin_python_setup(); do not run directly.
from catkin_pkg.python_setup import generate_distutils_setup
from setuptools import setup

setup(**generate_distutils_setup(packages=["telepresence", "telepresence.gui", "telepresence.ros"],
                                 package_dir={"": "src"}))
