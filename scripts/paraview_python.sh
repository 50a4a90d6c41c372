#!/bin/bash
# Unpacks Debian's python3-paraview (ParaView's Python modules, for pvbatch/pvpython and the
# plugin's wrapping) from apt's archive into DEST, without installing it: the package Conflicts
# with python3-vtk9 (both ship `vtkmodules`), and installing it would remove python3-vtk9 and
# libvtk9-dev, which udvr's own build needs. The version is the installed paraview's; a second
# run with that version unpacked does nothing. Usage: scripts/paraview_python.sh DEST
set -euo pipefail
dest=${1:?usage: paraview_python.sh DEST}
version=$(dpkg-query -W -f='${Version}' paraview 2>/dev/null) || {
    echo "paraview_python.sh: the paraview package is not installed" >&2
    exit 1
}
if [ "$(cat "$dest/.version" 2>/dev/null)" = "$version" ]; then
    exit 0
fi
work=$(mktemp -d)
trap 'rm -rf "$work" "$dest.tmp"' EXIT
# apt-get download fetches as the user _apt where it is run as root: let it write there.
if [ "$(id -u)" -eq 0 ] && id _apt >/dev/null 2>&1; then chown _apt "$work"; fi
(cd "$work" && apt-get download -qq "python3-paraview=$version" >&2)
mkdir -p "$(dirname "$dest")"
rm -rf "$dest.tmp"
dpkg-deb -x "$work"/python3-paraview_*.deb "$dest.tmp"
echo "$version" > "$dest.tmp/.version"
rm -rf "$dest"
mv "$dest.tmp" "$dest"
echo "paraview_python.sh: python3-paraview $version unpacked into $dest" >&2
