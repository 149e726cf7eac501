"""The ROS 2 tests (a package, so that tests/ros2/conftest.py does not replace tests/conftest.py as ``conftest``)."""
