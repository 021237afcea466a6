# The ROS 2 environment of this prefix (a venv made by `make setup`, or any install of the suite),
# as a colcon install's setup.bash gives it: `source <prefix>/setup.bash` (the venv's activate does).
# Keeps what a sourced ROS 2 Jazzy install already set: our prefix goes in front of AMENT_PREFIX_PATH,
# ROS_DISTRO / ROS_VERSION / ROS_PYTHON_VERSION are set only where unset.
_amr_prefix="$(cd "$(dirname "${BASH_SOURCE[0]:-$0}")" && pwd)"
case ":${AMENT_PREFIX_PATH:-}:" in
  *":$_amr_prefix:"*) ;;
  *) export AMENT_PREFIX_PATH="$_amr_prefix${AMENT_PREFIX_PATH:+:$AMENT_PREFIX_PATH}" ;;
esac
export ROS_DISTRO="${ROS_DISTRO:-jazzy}"
export ROS_VERSION="${ROS_VERSION:-2}"
export ROS_PYTHON_VERSION="${ROS_PYTHON_VERSION:-3}"
unset _amr_prefix
