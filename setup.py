"""Installs the offboard_py Python package from src/ (called by catkin_python_setup())."""
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(
    packages=['offboard_py', 'offboard_py.dialects', 'offboard_py.sim', 'offboard_py.sim.mavlink',
              'offboard_py.sim.navigator', 'offboard_py.bridge', 'offboard_py.testing', 'offboard_py.conversation',
              'offboard_py.tools'],
    package_dir={'': 'src'},
    package_data={'offboard_py.sim': ['px4_params.tsv'], 'offboard_py.dialects': ['px4_development.xml']}))
