#!/usr/bin/env bash
# Sets up legato-drake on a fresh machine: system libraries for headless rendering, a virtual
# environment with the CPU build of torch, and the package (editable) with its dev tools.
# Usage: bash scripts/setup.sh [VENV_DIR]   (default .venv). Safe to run again.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${1:-.venv}"

# Headless EGL/OpenGL for Drake's VTK renderer, and graphviz to draw diagrams.
packages=(libegl1 libgl1 libegl-mesa0 libgl1-mesa-dri libglx-mesa0 graphviz)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  if [ "$(id -u)" = 0 ]; then
    echo "setup: installing system packages: ${missing[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  else
    echo "setup: please install these system packages first: ${missing[*]}" >&2
    exit 1
  fi
fi

if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
pip=("$venv/bin/python" -m pip install --quiet --disable-pip-version-check)
# torch first and pinned: this resolves to the CPU build (an unpinned torch pulls CUDA).
"${pip[@]}" "torch==2.13.0"
# Then the package with the exact set that passed the tests (requirements/constraints.txt),
# on the Python it was resolved with; elsewhere from pyproject.toml's compatible ranges.
constraints=requirements/constraints.txt
locked=$(sed -n 's/^# Resolved with CPython \([0-9.]*\) .*/\1/p' "$constraints")
have=$("$venv/bin/python" -c 'import sys; print("%d.%d" % sys.version_info[:2])')
if [ "$have" = "$locked" ]; then
  "${pip[@]}" -c "$constraints" -e ".[dev]"
else
  echo "setup: Python $have, but $constraints was resolved with $locked:" \
       "installing from pyproject.toml's ranges instead" >&2
  "${pip[@]}" -e ".[dev]"
fi
echo "setup: ready ($venv)"
