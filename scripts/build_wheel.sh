#!/usr/bin/env bash
# Builds a wheel of the Python module from a configured and built CMake tree, offline and
# with Debian's packages only: the module, and libpcl_mi in pcl_mi.libs/ next to it (the
# module's RPATH looks there). PCL, OpenCL and the C++ runtime come from the system.
#   bash scripts/build_wheel.sh [BUILD_DIR [OUT_DIR [PYTHON]]]
#   (defaults: build, dist, and the interpreter the module was built for: /usr/bin/python3)
# Install it with pip into any environment of the same Python version:
#   python -m pip install OUT_DIR/pcl_mi-*.whl
set -euo pipefail
cd "$(dirname "$0")/.."
build=$(cd "${1:-build}" && pwd)
mkdir -p "${2:-dist}"
out=$(cd "${2:-dist}" && pwd)
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
cmake --install "$build" --prefix "$stage/prefix" > "$stage/install.log"
module=$(find "$stage/prefix" -name 'pcl_mi.cpython-*.so' | head -n 1)
[ -n "$module" ] || { echo "build_wheel: $build has no Python module (PCL_MI_WITH_PYTHON)"; exit 1; }
python=${3:-/usr/bin/python3}
suffix=$("$python" -c "import sysconfig; print(sysconfig.get_config_var('EXT_SUFFIX'))")
[ "$(basename "$module")" = "pcl_mi$suffix" ] ||
  { echo "build_wheel: $(basename "$module") was not built for $python ($suffix)"; exit 1; }
mkdir -p "$stage/wheel/pcl_mi.libs"
cp "$module" "$stage/wheel/"
library=$(find "$stage/prefix" -name 'libpcl_mi.so.*' -type f | head -n 1)
soname=$(objdump -p "$library" | awk '/SONAME/ {print $2}')
cp "$library" "$stage/wheel/pcl_mi.libs/$soname"
version=$(grep -m1 '^CMAKE_PROJECT_VERSION:' "$build/CMakeCache.txt" | cut -d= -f2)
"$python" - "$stage/wheel" "$out" "$version" <<'PY'
import base64, hashlib, os, sys, sysconfig, zipfile
root, out, version = sys.argv[1:]
tag = f"cp{sys.version_info.major}{sys.version_info.minor}"
platform = sysconfig.get_platform().replace("-", "_").replace(".", "_")
info = f"pcl_mi-{version}.dist-info"
os.makedirs(os.path.join(root, info))
meta = {"METADATA": f"Metadata-Version: 2.1\nName: pcl_mi\nVersion: {version}\n"
                    "Summary: 3D scan alignment by maximising the mutual information of voxel "
                    "features\nLicense: BSD-3-Clause\nRequires-Dist: numpy\n",
        "WHEEL": f"Wheel-Version: 1.0\nGenerator: pcl_mi build_wheel.sh\nRoot-Is-Purelib: false\n"
                 f"Tag: {tag}-{tag}-{platform}\n"}
for name, text in meta.items():
    open(os.path.join(root, info, name), "w").write(text)
records = []
for folder, _, files in os.walk(root):
    for f in files:
        path = os.path.join(folder, f)
        data = open(path, "rb").read()
        digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        records.append(f"{os.path.relpath(path, root)},sha256={digest},{len(data)}")
records.append(f"{info}/RECORD,,")
open(os.path.join(root, info, "RECORD"), "w").write("\n".join(records) + "\n")
wheel = os.path.join(out, f"pcl_mi-{version}-{tag}-{tag}-{platform}.whl")
with zipfile.ZipFile(wheel, "w", zipfile.ZIP_DEFLATED) as z:
    for folder, _, files in os.walk(root):
        for f in files:
            path = os.path.join(folder, f)
            z.write(path, os.path.relpath(path, root))
print("built", wheel)
PY
