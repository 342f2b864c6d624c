#!/usr/bin/env bash
# Tests scripts/get_data.sh against a local file:// mirror: the shared copy of the data set laid
# out as the mirror repository is (<commit>/code/victoria_park/...) in a temporary folder. Checks a
# good fetch (curl and python3), a data set already in place (nothing downloaded), a corrupted
# file (one byte changed) and an unreachable mirror (no partial files, one clear message).
#   test/get_data_test.sh            (the source copy: $VP_SOURCE, default $VP_DATA)
# Exits non-zero on any failure; nothing is written outside a temporary folder.
set -eo pipefail
# shellcheck source-path=SCRIPTDIR source=../scripts/env.sh
source "$(dirname "${BASH_SOURCE[0]}")/../scripts/env.sh"
get_data=$EKF_SLAM_ROOT/scripts/get_data.sh
src=${VP_SOURCE:-$VP_DATA}

# The checksums of the shared copy's README.md, kept here apart from the script under test.
expected='6ce2c4f757023b7d275cc14f24ff2ffcca21ea68cfa360bc854e620a706eb358  aa3_dr.mat
521fc4c6e0ea3851ffb463c3d9c0578044e9178c4fb87f37c703bb587f38c755  aa3_gpsx.mat
6fa0c0810327aba5f009c8e7fbbe28e2c63501fc046c1a79f8ba1ce8776a314d  lasersampling.txt
59df9e74c87d036d06f120b486d0806bc8626f6b8b0162b7126af1e1e1576fa1  victoria_park_ascii.zip
48ada1889e585098a81f07fbc1cedaa62e763d590dcb48b45bf62e4dc3cf7e2b  victoria_park_ascii/DRS.txt
7dcfdf85208479e307f3a72793686cda5b7f68dc410809996f68c67eda937edc  victoria_park_ascii/Documentation.txt
995042fbb8e938078a7eb75ece7e3ec168e2441325afb6cb804ac597ee0da0e6  victoria_park_ascii/GPS.txt
5f82c2d23bd440a77ca50f132c65499c3442cd884308acd8d1189f393e6593ca  victoria_park_ascii/LASER.txt
b069e0f2c4f6e50c940d3bde3e2c5bbcd2f17b2cb45e837d04bb767a10f32671  victoria_park_ascii/Sensors_manager.txt'

for f in aa3_dr.mat aa3_gpsx.mat lasersampling.txt victoria_park_ascii.zip; do
  if [[ ! -f $src/$f ]]; then
    echo "get_data_test: $src/$f is missing: set VP_SOURCE (or VP_DATA) to a copy of the data set" >&2
    exit 2
  fi
done

work=$(mktemp -d /tmp/get_data_test.XXXXXX)
trap 'rm -rf "$work"' EXIT
commit=0123456789abcdef0123456789abcdef01234567  # a made-up commit folder
mirror=$work/mirror/$commit
mkdir -p "$mirror/code/victoria_park/VictoriaParkDataSet"
cp "$src/aa3_dr.mat" "$src/aa3_gpsx.mat" "$src/lasersampling.txt" "$mirror/code/victoria_park/"
cp "$src/victoria_park_ascii.zip" "$mirror/code/victoria_park/VictoriaParkDataSet/"
# The same with one byte of the zip changed (the last file fetched: three are already downloaded
# when it fails).
bad=$work/bad/$commit
mkdir -p "$work/bad"
cp -r "$mirror" "$bad"
/usr/bin/python3 - "$bad/code/victoria_park/VictoriaParkDataSet/victoria_park_ascii.zip" <<'PY'
import sys
with open(sys.argv[1], "r+b") as f:
    f.seek(1000)
    b = f.read(1)
    f.seek(1000)
    f.write(bytes([b[0] ^ 0x01]))
PY
# A port nothing listens on: the mirror is unreachable (as without a network, but fast).
port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')

passed=0
failed=0
ok() { passed=$((passed + 1)); echo "ok      $1"; }
fail() { failed=$((failed + 1)); echo "FAILED  $1"; [[ -z ${2:-} ]] || echo "        ${2//$'\n'/$'\n'        }"; }
# run NAME ENV...: runs get_data.sh with those variables; sets rc, out (stdout) and err (stderr).
run() {
  local name=$1
  shift
  rc=0
  env "$@" "$get_data" > "$work/$name.out" 2> "$work/$name.err" || rc=$?
  out=$(cat "$work/$name.out")
  err=$(cat "$work/$name.err")
}
# Every path below a folder (hidden ones too) with size, mtime and inode, and every file's sha256.
snapshot() { (cd "$1" && find . -mindepth 1 -print0 | sort -z | xargs -0 stat -c '%n %s %Y %i' && find . -type f -print0 | sort -z | xargs -0 sha256sum); }
# verified DIR: all nine files there with the right sha256, nothing else.
verified() {
  local dir=$1 listing
  (cd "$dir" && sha256sum --quiet -c <<< "$expected") 2>&1 || return 1
  listing=$(cd "$dir" && find . -mindepth 1 | sort | tr '\n' ' ')
  [[ $listing == "./aa3_dr.mat ./aa3_gpsx.mat ./lasersampling.txt ./victoria_park_ascii ./victoria_park_ascii.zip ./victoria_park_ascii/DRS.txt ./victoria_park_ascii/Documentation.txt ./victoria_park_ascii/GPS.txt ./victoria_park_ascii/LASER.txt ./victoria_park_ascii/Sensors_manager.txt " ]] \
    || { echo "unexpected files: $listing"; return 1; }
}

# 1. A good fetch into a folder that does not exist yet, with each downloader.
for downloader in curl python3; do
  if [[ $downloader == curl ]] && ! command -v curl > /dev/null; then
    echo "skipped good fetch with curl: curl is not installed"
    continue
  fi
  dest=$work/data_$downloader/victoria_park
  run "good_$downloader" VP_DATA="$dest" VP_DATA_MIRROR="file://$mirror" VP_DATA_DOWNLOADER=$downloader
  if [[ $rc -ne 0 ]]; then
    fail "good fetch ($downloader): exit $rc" "$err"
  elif ! problems=$(verified "$dest"); then
    fail "good fetch ($downloader): the files do not verify" "$problems"
  elif ! grep -qxF "VP_DATA=$dest" <<< "$out"; then
    fail "good fetch ($downloader): it does not say where the files are" "$out"
  else
    ok "good fetch ($downloader): 9 files verified (4 downloaded, 5 unpacked), VP_DATA=$dest printed"
  fi
done
good=$work/data_python3/victoria_park

# 2. The data set already in place: nothing downloaded (the mirror is unreachable, so any download
# would fail) and nothing touched.
before=$(snapshot "$good")
run present VP_DATA="$good" VP_DATA_MIRROR="http://127.0.0.1:$port/$commit"
if [[ $rc -eq 0 && $out$err == *"nothing downloaded"* && $(snapshot "$good") == "$before" ]]; then
  ok "already present: exit 0, nothing downloaded, nothing changed"
else
  fail "already present: exit $rc" "$out$err"
fi
# Also a read-only copy that verifies (the shared one in CI).
if (cd "$src" && sha256sum --quiet -c <<< "$expected") > /dev/null 2>&1; then
  run present_src VP_DATA="$src" VP_DATA_MIRROR="http://127.0.0.1:$port/$commit"
  if [[ $rc -eq 0 && $out$err == *"nothing downloaded"* ]]; then
    ok "already present ($src): exit 0, nothing downloaded"
  else
    fail "already present ($src): exit $rc" "$out$err"
  fi
fi

# 3. A corrupted file: non-zero exit and VP_DATA as it was, both when it did not exist and when it
# held an incomplete set (one of the files, the wrong content in another).
dest=$work/corrupt_new/victoria_park
run corrupt_new VP_DATA="$dest" VP_DATA_MIRROR="file://$bad"
if [[ $rc -ne 0 && ! -e $dest && ! -e $work/corrupt_new && $err == *"victoria_park_ascii.zip"*corrupted* ]]; then
  ok "corrupted zip, new folder: exit $rc, no folder created, the corrupted file named"
else
  fail "corrupted zip, new folder: exit $rc, $(find "$work/corrupt_new" 2> /dev/null | wc -l) paths left" "$err"
fi
dest=$work/corrupt_old
mkdir -p "$dest"
cp "$src/aa3_dr.mat" "$dest/"
echo "not the GPS file" > "$dest/aa3_gpsx.mat"
before=$(snapshot "$dest")
run corrupt_old VP_DATA="$dest" VP_DATA_MIRROR="file://$bad"
if [[ $rc -ne 0 && $(snapshot "$dest") == "$before" && $err == *corrupted* ]]; then
  ok "corrupted zip, incomplete folder: exit $rc, the folder unchanged (no partial or temporary files)"
else
  fail "corrupted zip, incomplete folder: exit $rc" "$err"$'\n'"$(diff <(echo "$before") <(snapshot "$dest"))"
fi
# The same with the python3 downloader, and a file missing at the mirror.
dest=$work/corrupt_py/victoria_park
run corrupt_py VP_DATA="$dest" VP_DATA_MIRROR="file://$bad" VP_DATA_DOWNLOADER=python3
if [[ $rc -ne 0 && ! -e $dest && $err == *corrupted* ]]; then
  ok "corrupted zip (python3): exit $rc, nothing written"
else
  fail "corrupted zip (python3): exit $rc" "$err"
fi
rm "$bad/code/victoria_park/lasersampling.txt"
dest=$work/missing/victoria_park
run missing VP_DATA="$dest" VP_DATA_MIRROR="file://$bad"
if [[ $rc -eq 3 && ! -e $dest && $err == *"lasersampling.txt is not at the mirror"* ]]; then
  ok "file missing at the mirror: exit 3, nothing written"
else
  fail "file missing at the mirror: exit $rc" "$err"
fi

# 4. An unreachable mirror: one clear message with the manual steps, non-zero exit, nothing written.
for downloader in curl python3; do
  [[ $downloader == curl ]] && ! command -v curl > /dev/null && continue
  dest=$work/offline_$downloader/victoria_park
  run "offline_$downloader" VP_DATA="$dest" VP_DATA_MIRROR="http://127.0.0.1:$port/$commit" \
    VP_DATA_DOWNLOADER=$downloader
  errors=$(grep -c '^get_data.sh: ' <<< "$err" || true)
  if [[ $rc -eq 4 && ! -e $dest && $errors -eq 1 && $err == *"cannot reach the mirror"* \
        && $err == *"To get the data by hand"* \
        && $err == *"https://raw.githubusercontent.com/OpenSLAM-org/openslam_ufastslam/70e621ed8b039e79f0cf5b5b902e87dcffd6e4fa/code/victoria_park/VictoriaParkDataSet/victoria_park_ascii.zip"* ]]; then
    ok "unreachable mirror ($downloader): exit 4, one message with the manual steps, nothing written"
  else
    fail "unreachable mirror ($downloader): exit $rc, $errors message lines" "$err"
  fi
done

echo "get_data_test: $passed passed, $failed failed"
[[ $failed -eq 0 && $passed -gt 0 ]]
