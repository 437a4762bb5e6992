#!/usr/bin/env bash
# Set up JOSHUA on Debian with Python 3.11 in ./.venv, or with Python 3.12 in ./.venv-3.12 (beside it, so one
# checkout can hold both):
#   PYTHON=python3.12 ./setup.sh --dev   or   ./setup.sh --dev --python 3.12   (an X.Y, a command or a path)
#   ./setup.sh          the runtime: joshua-core, joshua-render (rendering, video, viewer), the joshua-mujoco backend,
#                       joshua-modes (viewer, replay, offscreen), joshua-tasks (the robots' tasks)
#   ./setup.sh --all    every plugin and the web display (viser): also joshua-mirror (rclpy + Fast DDS wheels, no ROS install),
#                       joshua-sb3 (stable-baselines3 with torch: its CPU wheel on 3.11), joshua-mjx and joshua-ppo
#                       (MJX with MuJoCo Warp, JAX, Flax, Optax; JAX for the CPU: on a GPU machine add
#                       pip install "jax[cuda13]") with joshua-jax, the compile cache they share
#                       joshua-usd with its physx extra (usd-core: USD robots on MuJoCo, export to Isaac; ovphysx,
#                       ovstage and physx-usd-schemas: PhysX and its USD schemas, ~203 MB of wheels), joshua-sysid
#                       (joshua sysid: fit servo and joint parameters to recordings with mujoco.sysid),
#                       joshua-export (onnx, onnxruntime: `joshua export` writes policies as ONNX with their contract) and
#                       joshua-lerobot (LeRobot datasets in and out: pyarrow, PyAV)
#   ./setup.sh --dev    --all and what the tests need: pytest, ruff, protoc (grpcio-tools), trimesh,
#                       Gymnasium's MuJoCo environments (the reference of bench/cpu_env_throughput.py),
#                       Xvfb, xwd and xdotool for the viewer tests, chromium and its driver for the web display's, the real lerobot
#                       for joshua-lerobot's tests (0.4.4 on 3.11 in .cache/lerobot-site, 0.6 on 3.12 in
#                       .cache/lerobot-site-3.12; with FFmpeg's libraries from apt), and NVIDIA's
#                       mujoco-usd-converter for joshua-usd's in .cache/usd-converter (a venv of its own)
# Versions come from constraints.txt. pip's cache stays inside the clone (.cache/pip).
set -euo pipefail
cd "$(dirname "$0")"

SYSTEM_PACKAGES=(
  libegl1 libegl-mesa0 libgl1-mesa-dri libopengl0  # EGL: headless rendering without a display
  libosmesa6                                       # OSMesa: the software fallback when EGL does not work
  libgl1 libglx-mesa0                              # GLX (Mesa, llvmpipe without a GPU): the MuJoCo viewer's OpenGL
  libx11-6 libx11-xcb1 libxcursor1 libxext6 libxi6 libxinerama1 libxrandr2 libxrender1 libxxf86vm1  # GLFW on X11
)
usage() {
  echo "usage: [PYTHON=python3.12] ./setup.sh [--all | --dev] [--python 3.12]${1:+: $1}" >&2
  exit 2
}
option=
PYTHON=${PYTHON:-}
while (($#)); do
  case $1 in
    --all | --dev) [[ -z $option ]] || usage "one of --all and --dev"; option=$1 ;;
    --python) (($# > 1)) || usage "--python needs a value"; PYTHON=$2; shift ;;
    --python=*) PYTHON=${1#--python=} ;;
    *) usage "unknown argument $1" ;;
  esac
  shift
done
if [[ -z $PYTHON ]]; then
  PYTHON=python3.11
  command -v "$PYTHON" >/dev/null || PYTHON=python3
fi
[[ $PYTHON =~ ^[0-9]+\.[0-9]+$ ]] && PYTHON=python$PYTHON  # --python 3.12
# pyenv's shim for python3.12 refuses to run unless 3.12 is selected (pyenv shell/local); take the newest 3.12 it has
if ! "$PYTHON" -c '' 2>/dev/null && [[ $PYTHON =~ ^python(3\.[0-9]+)$ ]] && command -v pyenv >/dev/null; then
  pyenv_version=$(pyenv versions --bare 2>/dev/null | grep -E "^${BASH_REMATCH[1]//./\\.}\.[0-9]+$" | sort -V | tail -1)
  [[ -n $pyenv_version ]] && PYTHON=$(pyenv root)/versions/$pyenv_version/bin/$PYTHON
fi
if ! python_version=$("$PYTHON" -c 'import sys; print("%d.%d" % sys.version_info[:2])' 2>/dev/null); then
  echo "setup: cannot run Python '$PYTHON' (PYTHON or --python)" >&2
  exit 2
fi
case $python_version in
  3.11) venv=.venv lerobot_site=.cache/lerobot-site ;;
  3.12) venv=.venv-3.12 lerobot_site=.cache/lerobot-site-3.12 ;;  # compiled for its Python: one per version
  *) echo "setup: $PYTHON is Python $python_version; JOSHUA is set up on 3.11 or 3.12" >&2; exit 2 ;;
esac
if [[ -x $venv/bin/python ]]; then
  made_by=$("$venv/bin/python" -c 'import sys; print("%d.%d" % sys.version_info[:2])' 2>/dev/null || echo unknown)
  if [[ $made_by != "$python_version" ]]; then  # an environment setup may not have made: left for its owner to remove
    echo "setup: $venv holds Python $made_by, not $python_version: move it away, then run setup again" >&2
    exit 2
  fi
fi
if [[ $option == --dev ]]; then
  SYSTEM_PACKAGES+=(xvfb x11-apps xdotool)  # viewer tests: a virtual X server, xwd screenshots, closing the window
  SYSTEM_PACKAGES+=(chromium chromium-driver)  # web display tests: a real headless browser
  SYSTEM_PACKAGES+=(libavcodec59 libavformat59 libavutil57 libswscale6 libswresample4 libavfilter8 libavdevice59)  # FFmpeg for torchcodec (the lerobot tests)
fi
missing=()
for package in "${SYSTEM_PACKAGES[@]}"; do
  dpkg -s "$package" >/dev/null 2>&1 || missing+=("$package")
done
if ((${#missing[@]})); then
  echo "setup: installing system packages: ${missing[*]}"
  sudo_cmd=()
  [[ $(id -u) == 0 ]] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq "${missing[@]}"
fi

echo "setup: Python $python_version ($PYTHON) in $venv"
[[ -x $venv/bin/python ]] || "$PYTHON" -m venv "$venv"
export PIP_CACHE_DIR="$PWD/.cache/pip" PIP_DISABLE_PIP_VERSION_CHECK=1
pinned_mujoco=$(sed -n 's/^mujoco==\([^ ]*\).*/\1/p' constraints.txt)
installed_mujoco=$("$venv/bin/python" -c 'from importlib.metadata import version; print(version("mujoco"))' 2>/dev/null || true)
if [[ -n $installed_mujoco && $installed_mujoco != "$pinned_mujoco" ]]; then
  # mujoco 4 split its compiled library into mujoco-core: upgraded in place, files one version's package owns can be
  # removed by the other's uninstall, so both go first and the pinned pair is installed afresh below
  echo "setup: replacing mujoco $installed_mujoco with $pinned_mujoco"
  "$venv/bin/pip" uninstall -q -y mujoco mujoco-core
fi
# --no-compile: pip byte-compiles one file after another; compile_sites below does it on every core once the
# packages are in (left to Python's first import instead, the tests' processes compiled the same modules side by
# side and a clean clone's pytest took 70 s longer)
pip_install=("$venv/bin/pip" install -q --no-compile)
compile_sites() { "$venv/bin/python" -m compileall -q -j 0 "$@" >/dev/null || true; }  # a file that fails stays source

# lerobot 0.4.4 on Python 3.11; lerobot 0.6 needs 3.12, and its pins are a file of their own
LEROBOT_REQUIREMENTS=plugins/joshua-lerobot/tests/lerobot-requirements.txt
[[ $python_version == 3.11 ]] || LEROBOT_REQUIREMENTS=plugins/joshua-lerobot/tests/lerobot-requirements-$python_version.txt
lerobot_job=
if [[ $option == --dev ]] && ! cmp -s "$LEROBOT_REQUIREMENTS" "$lerobot_site/requirements.txt"; then
  # the real lerobot for joshua-lerobot's tests, beside the venv, not in it: its pins (torch<2.11 ...) must not change
  # the venv; reinstalled whole when the pins change (the site keeps a copy of the requirements it was installed from).
  # It needs nothing from the venv but its pip, so it installs while the venv's packages do (downloads overlap).
  echo "setup: installing lerobot (tests only) into $lerobot_site, beside $venv's packages"
  rm -rf "$lerobot_site.partial"
  "${pip_install[@]}" --no-deps --target "$lerobot_site.partial" -r "$LEROBOT_REQUIREMENTS" &
  lerobot_job=$!
  trap 'kill $lerobot_job 2>/dev/null || true' EXIT  # a setup that stops early stops it too
fi

requirements=(-e . -e plugins/joshua-render -e plugins/joshua-mujoco -e plugins/joshua-modes -e plugins/joshua-tasks)
if [[ -n $option ]]; then
  requirements=("${requirements[@]/plugins\/joshua-render/plugins/joshua-render[web]}")  # --web: the browser display
  requirements+=(-e plugins/joshua-mirror -e plugins/joshua-sb3 -e plugins/joshua-jax -e 'plugins/joshua-mjx[warp]' -e plugins/joshua-ppo -e plugins/joshua-usd -e plugins/joshua-sysid -e plugins/joshua-export -e plugins/joshua-lerobot)
  # torch first, pinned: then stable-baselines3 finds it installed and pulls nothing more. On 3.11 the pin is the
  # CPU wheel; for 3.12 PyPI has only CUDA builds, and constraints.txt pins the one that downloads least
  echo "setup: installing torch into $venv"
  "${pip_install[@]}" -c constraints.txt torch
fi
if [[ $option == --dev ]]; then
  requirements=(-e ".[dev,plots]" "${requirements[@]:2}" "gymnasium[mujoco]")
fi
echo "setup: installing ${requirements[*]} into $venv"
"${pip_install[@]}" -c constraints.txt "${requirements[@]}"
if [[ -n $option && $python_version != 3.11 ]]; then
  # PyPI's CUDA torch pulls triton, torch.compile's GPU kernel compiler, which nothing here uses; torch probes for it
  # when an optimizer is made, and importing it in a process that has the simulation loaded crashes (stable-baselines3's
  # PPO.load in joshua-export's tests). Without it torch runs on the CPU as its CPU wheel does.
  "$venv/bin/pip" uninstall -q -y triton
fi
if [[ -n $option ]]; then
  # joshua-usd[physx] without dependencies: ovphysx pins packaging<24, pytest 9 and hatchling need packaging>=24, and
  # ovphysx runs with packaging 25. Its other requirements are here: ovstage (installed with it) and warp-lang
  # (joshua-mjx[warp], in ovphysx's range); physx-usd-schemas has none. So `pip check` reports that pin alone.
  echo "setup: installing joshua-usd[physx] (ovphysx, ovstage, physx-usd-schemas) into $venv"
  "${pip_install[@]}" -c constraints.txt --no-deps ovphysx ovstage physx-usd-schemas
fi
compile_sites "$venv/lib"
CONVERTER_REQUIREMENTS=plugins/joshua-usd/tests/converter-requirements.txt
if [[ $option == --dev ]] && ! cmp -s $CONVERTER_REQUIREMENTS .cache/usd-converter/requirements.txt; then
  # NVIDIA/Newton's mujoco-usd-converter for joshua-usd's tests, in a venv of its own: it pins mujoco<3.17 and its
  # usd-exchange ships a `pxr` that must not share an environment with usd-core. Rebuilt whole when the pins change
  # (the venv keeps a copy of the requirements it was installed from, written last). One serves both Pythons' setups:
  # it is a program the tests run, whichever Python it was made with.
  echo "setup: installing mujoco-usd-converter (tests only) into .cache/usd-converter"
  rm -rf .cache/usd-converter
  "$PYTHON" -m venv --without-pip .cache/usd-converter
  "$venv/bin/pip" --python .cache/usd-converter/bin/python install -q --no-deps -r $CONVERTER_REQUIREMENTS
  cp $CONVERTER_REQUIREMENTS .cache/usd-converter/requirements.txt
fi
if [[ -n $lerobot_job ]]; then
  wait $lerobot_job  # its failure fails the setup (set -e)
  compile_sites "$lerobot_site.partial"
  cp "$LEROBOT_REQUIREMENTS" "$lerobot_site.partial/requirements.txt"
  rm -rf "$lerobot_site"
  mv "$lerobot_site.partial" "$lerobot_site"
fi
echo "setup: done; run $venv/bin/joshua --help"
