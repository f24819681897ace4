#!/usr/bin/env bash
# Builds msgs/ (the terzaghi_msgs ROS 2 package) and tests/python/tf2_msgs (tf2_msgs's
# TFMessage, which the PyPI wheels lack) with colcon, from ROS 2's PyPI wheels in the
# virtual environment VENV, into OUT/install; then `source OUT/env.sh` gives a Python with
# the generated message classes (from terzaghi_msgs.msg import LegForce, ModelParams;
# from tf2_msgs.msg import TFMessage).
#
#   tests/python/build_msgs.sh VENV OUT
#
# Two things the PyPI wheels leave undone, done here:
# - they install into VENV as a ROS prefix, but nothing puts VENV on AMENT_PREFIX_PATH and
#   CMAKE_PREFIX_PATH, where ament and CMake look for packages;
# - their CMake exports name the include directories of the machine that built them
#   (/opt/python/cp311-cp311/...): they are rewritten to VENV's Python and NumPy headers.
set -euo pipefail
venv=$(cd "$1" && pwd)
out=$(mkdir -p "$2" && cd "$2" && pwd)
repo=$(cd "$(dirname "$0")/../.." && pwd)
py="$venv/bin/python"
py_include=$("$py" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')
np_include=$("$py" -c 'import numpy; print(numpy.get_include())')
{ grep -rlE '/opt/python/cp3[0-9]+-cp3[0-9]+' "$venv/share" --include='*.cmake' || true; } |
  xargs -r sed -i -E \
    -e "s#/opt/python/cp3[0-9]+-cp3[0-9]+/include/python3\.[0-9]+#$py_include#g" \
    -e "s#/opt/python/cp3[0-9]+-cp3[0-9]+/lib/python3\.[0-9]+/site-packages/numpy/_core/include#$np_include#g"
export AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv" PATH="$venv/bin:$PATH"
rm -rf "$out/build" "$out/install"
(cd "$out" && colcon --log-base "$out/log" build --base-paths "$repo/msgs" "$repo/tests/python/tf2_msgs" \
  --build-base "$out/build" --install-base "$out/install" --event-handlers console_direct- )
prefix="$out/install/terzaghi_msgs"
tf2="$out/install/tf2_msgs"
pyver=$("$py" -c 'import sys; print(f"python{sys.version_info[0]}.{sys.version_info[1]}")')
cat > "$out/env.sh" <<ENV
# The environment in which VENV's Python imports terzaghi_msgs and tf2_msgs (made by build_msgs.sh).
export AMENT_PREFIX_PATH="$prefix:$tf2:$venv"
export PYTHONPATH="$prefix/lib/$pyver/site-packages:$tf2/lib/$pyver/site-packages\${PYTHONPATH:+:\$PYTHONPATH}"
export LD_LIBRARY_PATH="$prefix/lib:$tf2/lib\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}"
ENV
# Importing the message classes opens no DDS participant: safe out here.
(source "$out/env.sh" && "$py" -c 'from terzaghi_msgs.msg import LegForce, ModelParams; from tf2_msgs.msg import TFMessage')
echo "built terzaghi_msgs into $prefix, tf2_msgs into $tf2"
