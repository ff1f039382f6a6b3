"""./run's set-up on a machine that already has ROS (Ubuntu 20.04 with ROS Noetic in /opt/ros/noetic,
where most ROS 1 users are) and on one that has none (Debian 12, whose own packages ship ROS 1).

The set-up logic of ./run runs for real against a faked /opt/ros layout (a setup.bash and the
share/<package>/package.xml files a ROS installation has), with OFFBOARD_PY_DRY_RUN=1: it says what it
would install with apt and stops before the venv and the build. With a distribution there it must
name only that distribution's packages (ros-noetic-...) for what is missing, never Debian's ROS
package names beside it.
"""

import os
import subprocess

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
DEBIAN_ROS_NAMES = ('ros-core-python-dev', 'ros-message-generation', 'python3-rospy', 'python3-rostest',
                    'python3-roslaunch', 'libstd-msgs-dev', 'python3-geometry-msgs', 'rosbash')


def fake_ros(root, distro, packages):
    base = root / distro
    base.mkdir(parents=True)
    (base / 'setup.bash').write_text('export ROS_DISTRO=%s\n' % distro)
    for name in packages:
        (base / 'share' / name).mkdir(parents=True)
        (base / 'share' / name / 'package.xml').write_text('<package format="2"><name>%s</name></package>' % name)
    return root


def dry_run(ros_root, **env):
    full = {k: v for k, v in os.environ.items() if k != 'ROS_DISTRO'}
    full.update(OFFBOARD_PY_ROS_ROOT=str(ros_root), OFFBOARD_PY_DRY_RUN='1', **env)
    result = subprocess.run(['bash', os.path.join(REPO, 'run'), 'build'], env=full, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, universal_newlines=True, timeout=60)
    return result.returncode, result.stdout


def apt_names(out):
    lines = [line for line in out.splitlines() if 'would install with apt:' in line]
    return lines[0].split('would install with apt:')[1].split() if lines else []


def test_an_installed_noetic_is_used_and_completed_from_its_own_packages(tmp_path):
    root = fake_ros(tmp_path / 'opt' / 'ros', 'noetic', ['catkin', 'rospy', 'std_msgs', 'roslaunch'])
    code, out = dry_run(root)
    assert code == 0, out
    assert 'using ROS noetic from %s' % (root / 'noetic') in out, out
    names = apt_names(out)
    assert 'ros-noetic-message-generation' in names and 'ros-noetic-geometry-msgs' in names, out
    assert 'ros-noetic-rospy' not in names and 'ros-noetic-catkin' not in names, 'installed ones are not asked for'
    assert not set(names) & set(DEBIAN_ROS_NAMES), 'Debian ROS packages beside ROS noetic: %s' % names


def test_ros_distro_chooses_among_several_and_several_without_it_is_an_error(tmp_path):
    root = fake_ros(tmp_path / 'ros', 'noetic', ['catkin'])
    fake_ros(root, 'melodic', ['catkin'])
    code, out = dry_run(root)
    assert code != 0 and 'several ROS distributions' in out and 'melodic' in out and 'noetic' in out, out
    code, out = dry_run(root, ROS_DISTRO='melodic')
    assert code == 0 and 'using ROS melodic' in out and 'ros-melodic-rospy' in apt_names(out), out
    code, out = dry_run(root, ROS_DISTRO='humble')
    assert code != 0 and 'ROS_DISTRO=humble but' in out, out


def test_without_an_installed_distribution_debian_packages_are_used(tmp_path):
    code, out = dry_run(tmp_path / 'no-ros-here')
    assert code == 0, out
    assert "no ROS in %s: Debian's ROS packages" % (tmp_path / 'no-ros-here') in out, out
    assert 'using ROS' not in out and not [n for n in apt_names(out) if n.startswith(('ros-noetic', 'ros-melodic'))]


def test_debian_s_own_ros_distro_name_means_debian_s_packages(tmp_path):
    """A shell with the workspace sourced on Debian (./run shell) says ROS_DISTRO=Debian: ./run goes on
    with Debian's packages instead of looking for /opt/ros/Debian."""
    code, out = dry_run(tmp_path / 'no-ros-here', ROS_DISTRO='Debian')
    assert code == 0 and 'ROS_DISTRO=Debian but' not in out, out
    assert "Debian's ROS packages" in out, out
