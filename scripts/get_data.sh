#!/usr/bin/env bash
# Fetches the Victoria Park data set (ACFR) from the OpenSLAM UFastSLAM mirror at a pinned commit
# into $VP_DATA (see scripts/env.sh), checks the sha256 of every file and unpacks the ASCII
# release. Everything is downloaded and checked in a temporary folder inside $VP_DATA first, so a
# failed run leaves $VP_DATA as it was. --help lists the options, variables and exit codes.
set -eo pipefail
# shellcheck source-path=SCRIPTDIR source=env.sh
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"

me=get_data.sh
public_mirror=https://raw.githubusercontent.com/OpenSLAM-org/openslam_ufastslam/70e621ed8b039e79f0cf5b5b902e87dcffd6e4fa
mirror=${VP_DATA_MIRROR:-$public_mirror}
mirror=${mirror%/}

# name, path below the mirror, sha256, bytes (checksums from the shared copy's README.md).
downloads=(
  "aa3_dr.mat code/victoria_park/aa3_dr.mat 6ce2c4f757023b7d275cc14f24ff2ffcca21ea68cfa360bc854e620a706eb358 1239216"
  "aa3_gpsx.mat code/victoria_park/aa3_gpsx.mat 521fc4c6e0ea3851ffb463c3d9c0578044e9178c4fb87f37c703bb587f38c755 89624"
  "lasersampling.txt code/victoria_park/lasersampling.txt 6fa0c0810327aba5f009c8e7fbbe28e2c63501fc046c1a79f8ba1ce8776a314d 130482"
  "victoria_park_ascii.zip code/victoria_park/VictoriaParkDataSet/victoria_park_ascii.zip 59df9e74c87d036d06f120b486d0806bc8626f6b8b0162b7126af1e1e1576fa1 1951254"
)
# The five files at the root of victoria_park_ascii.zip, unpacked into victoria_park_ascii/.
unpacked=(
  "DRS.txt 48ada1889e585098a81f07fbc1cedaa62e763d590dcb48b45bf62e4dc3cf7e2b 1468022"
  "Documentation.txt 7dcfdf85208479e307f3a72793686cda5b7f68dc410809996f68c67eda937edc 692"
  "GPS.txt 995042fbb8e938078a7eb75ece7e3ec168e2441325afb6cb804ac597ee0da0e6 22094"
  "LASER.txt 5f82c2d23bd440a77ca50f132c65499c3442cd884308acd8d1189f393e6593ca 15549751"
  "Sensors_manager.txt b069e0f2c4f6e50c940d3bde3e2c5bbcd2f17b2cb45e837d04bb767a10f32671 1187361"
)

usage() {
  cat <<USAGE
Usage: scripts/get_data.sh [--force] [--quiet]

Downloads the Victoria Park data set from the OpenSLAM UFastSLAM mirror at a pinned commit,
checks the sha256 of every file (the zip and the five files in it too) and only then moves them
into \$VP_DATA. If the data is already there and verifies, it downloads nothing.

  -f, --force   download again even if \$VP_DATA already verifies
  -q, --quiet   print only errors and where the data is
  -h, --help    this text

Environment:
  VP_DATA         where the data goes and is looked for (now: $VP_DATA;
                  default ../shared/data/victoria_park beside the repository)
  VP_DATA_MIRROR  replaces the base URL $public_mirror
                  (e.g. file:///some/copy/<commit>); below it the files are at the mirror
                  repository's own paths, code/victoria_park/...
  VP_DATA_DOWNLOADER  curl (the default when installed) or python3 (urllib)

Layout in \$VP_DATA: aa3_dr.mat, aa3_gpsx.mat, lasersampling.txt, victoria_park_ascii.zip and
victoria_park_ascii/ (DRS.txt, Documentation.txt, GPS.txt, LASER.txt, Sensors_manager.txt).

Exit codes: 0 the data is in \$VP_DATA (downloaded or already there); 1 a file failed its check
(corrupted, truncated) or the zip did not unpack; 2 bad usage; 3 a file is missing at the mirror
(HTTP 404, no such file) or the server refused it; 4 no network or the mirror is unreachable (the
manual steps are printed); 5 a local problem (\$VP_DATA not writable, no downloader).
\$VP_DATA is left unchanged by every failure (a run killed with SIGKILL may leave a hidden
.get_data.* folder there; runs an hour or more later remove it).

The data set is ACFR's (Australian Centre for Field Robotics, University of Sydney; J. Guivant and
E. Nebot). If you use it, cite their work, for example: J. Guivant and E. Nebot, "Optimization of
the Simultaneous Localization and Map Building Algorithm for Real-Time Implementation", IEEE
Transactions on Robotics and Automation, 2001.
USAGE
}

force=0
quiet=0
for arg in "$@"; do
  case $arg in
    -h | --help) usage; exit 0 ;;
    -f | --force) force=1 ;;
    -q | --quiet) quiet=1 ;;
    *) echo "$me: unknown argument '$arg' (see --help)" >&2; exit 2 ;;
  esac
done

say() { (( quiet )) || echo "$@" >&2; }
[[ $VP_DATA == /* ]] || VP_DATA=$PWD/$VP_DATA
VP_DATA=${VP_DATA%/}

# Prints what is wrong with file $1 (expected sha256 $2, $3 bytes); prints nothing if it matches.
check() {
  local file=$1 sha=$2 size=$3 got got_size
  if [[ ! -f $file ]]; then echo "missing"; return 1; fi
  got=$(sha256sum < "$file") && got=${got%% *}
  [[ $got == "$sha" ]] && return 0
  got_size=$(stat -c %s "$file")
  if (( got_size < size )); then
    echo "truncated: $got_size of $size bytes (sha256 $got, expected $sha)"
  elif (( got_size > size )); then
    echo "too long: $got_size bytes, expected $size (sha256 $got, expected $sha)"
  else
    echo "corrupted: sha256 $got, expected $sha (size $size bytes as expected)"
  fi
  return 1
}

# Checks the nine files under folder $1; prints one line per problem.
check_all() {
  local dir=$1 entry name path sha size problem status=0
  for entry in "${downloads[@]}"; do
    read -r name path sha size <<< "$entry"
    problem=$(check "$dir/$name" "$sha" "$size") || { echo "$name: $problem"; status=1; }
  done
  for entry in "${unpacked[@]}"; do
    read -r name sha size <<< "$entry"
    problem=$(check "$dir/victoria_park_ascii/$name" "$sha" "$size") \
      || { echo "victoria_park_ascii/$name: $problem"; status=1; }
  done
  return $status
}

result() {
  echo "$me: $1"
  printf 'VP_DATA=%q\n' "$VP_DATA"
}

manual_steps() {
  local entry name path sha size
  echo "To get the data by hand, download these four files:"
  for entry in "${downloads[@]}"; do
    read -r name path sha size <<< "$entry"
    echo "  $public_mirror/$path"
  done
  cat <<STEPS
put them in $VP_DATA as
  aa3_dr.mat  aa3_gpsx.mat  lasersampling.txt  victoria_park_ascii.zip
and unpack the zip (five files at its root) into $VP_DATA/victoria_park_ascii/, e.g.
  /usr/bin/python3 -m zipfile -e victoria_park_ascii.zip victoria_park_ascii/
then run scripts/get_data.sh again: it checks them and exits 0. Or set VP_DATA to a folder
that has them. Meanwhile scripts/demo.sh runs a simulated world instead.
STEPS
}

if (( ! force )) && [[ -d $VP_DATA ]]; then
  if problems=$(check_all "$VP_DATA"); then
    result "the Victoria Park data set is already in $VP_DATA and verifies; nothing downloaded (--force downloads it again)."
    exit 0
  fi
  # Say what is wrong unless it is simply absent.
  if [[ -n $(find "$VP_DATA" -mindepth 1 -maxdepth 1 -print -quit) ]]; then
    say "$me: $VP_DATA is incomplete, downloading again:"
    say "  ${problems//$'\n'/$'\n'  }"
  fi
fi

# curl when installed, else Debian's python3 (urllib: http, https and file://), which the project
# needs anyway. VP_DATA_DOWNLOADER=python3 forces the second (the test uses it).
downloader=${VP_DATA_DOWNLOADER:-}
if [[ -z $downloader ]]; then
  if command -v curl > /dev/null; then downloader=curl; else downloader=python3; fi
fi
case $downloader in
  curl) command -v curl > /dev/null || downloader=missing ;;
  python3) [[ -x /usr/bin/python3 ]] || downloader=missing ;;
  *) echo "$me: VP_DATA_DOWNLOADER must be curl or python3, not '$downloader'" >&2; exit 2 ;;
esac
if [[ $downloader == missing ]]; then
  { echo "$me: neither curl nor /usr/bin/python3 is installed (apt-get install curl); nothing downloaded."
    manual_steps; } >&2
  exit 5
fi

# Folders this run creates for $VP_DATA: removed again if it fails, so that a failure leaves no
# trace. Outermost first.
created=()
dir=$VP_DATA
while [[ ! -e $dir ]]; do
  created=("$dir" "${created[@]}")
  dir=$(dirname "$dir")
done
tmp=
finished=0
cleanup() {
  [[ -n $tmp ]] && rm -rf "$tmp"
  if (( ! finished )); then
    local i
    for (( i = ${#created[@]} - 1; i >= 0; i-- )); do rmdir "${created[i]}" 2> /dev/null || true; done
  fi
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

# The temporary folder sits inside $VP_DATA: same file system, so the final moves are renames.
# Those of runs killed an hour ago or more go first.
if [[ -d $VP_DATA ]]; then
  find "$VP_DATA" -mindepth 1 -maxdepth 1 -type d -name '.get_data.*' -mmin +60 \
    -exec rm -rf {} + 2> /dev/null || true
fi
if ! mkdir -p "$VP_DATA" 2> /dev/null || ! tmp=$(mktemp -d "$VP_DATA/.get_data.XXXXXX" 2> /dev/null); then
  tmp=
  echo "$me: cannot create a folder in $VP_DATA (not writable?); set VP_DATA to another folder." >&2
  exit 5
fi

unchanged="nothing in $VP_DATA was changed"

# urllib's errors mapped onto curl's exit codes: 22 the server said no (HTTP >= 400) or no such
# file (file://), 7 no network (DNS, refused, timeout).
python_fetch='
import shutil, socket, sys, urllib.error, urllib.request
url, out = sys.argv[1], sys.argv[2]
try:
    with urllib.request.urlopen(url, timeout=30) as r, open(out, "wb") as f:
        shutil.copyfileobj(r, f)
except urllib.error.HTTPError as e:
    print(f"HTTP error {e.code}: {e.reason}")
    sys.exit(22)
except urllib.error.URLError as e:
    print(e.reason)
    sys.exit(22 if isinstance(e.reason, FileNotFoundError) else 7)
except (socket.timeout, TimeoutError, ConnectionError) as e:
    print(e)
    sys.exit(7)
'

# Downloads URL $1 to file $2. On failure sets kind (network, missing or other) and detail.
fetch() {
  local url=$1 out=$2 rc=0
  if [[ $downloader == curl ]]; then
    detail=$(curl --fail --silent --show-error --location --connect-timeout 20 \
      --speed-limit 1000 --speed-time 60 --retry 2 --retry-delay 1 -o "$out" "$url" 2>&1) || rc=$?
    case $rc in
      0) return 0 ;;
      5 | 6 | 7 | 28 | 35 | 52 | 55 | 56) kind=network ;;  # proxy, DNS, connect, timeout, TLS, reset
      22 | 37 | 78) kind=missing ;;                        # HTTP >= 400, no such file (file://, ftp)
      *) kind=other ;;
    esac
  else
    detail=$(/usr/bin/python3 -c "$python_fetch" "$url" "$out" 2>&1) || rc=$?
    case $rc in
      0) return 0 ;;
      7) kind=network ;;
      22) kind=missing ;;
      *) kind=other ;;
    esac
  fi
  # curl repeats its message for every retry: keep the last line.
  detail=$(grep -v '^ *$' <<< "$detail" | tail -n 1) || true
  [[ -n $detail ]] || detail="$downloader exit code $rc"
  return 1
}

say "Downloading the Victoria Park data set into $VP_DATA from $mirror"
for entry in "${downloads[@]}"; do
  read -r name path sha size <<< "$entry"
  url=$mirror/$path
  if ! fetch "$url" "$tmp/$name"; then
    case $kind in
      network)
        { echo "$me: cannot reach the mirror for $name ($detail); $unchanged."
          manual_steps; } >&2
        exit 4 ;;
      missing)
        echo "$me: $name is not at the mirror: $url ($detail); $unchanged." >&2
        exit 3 ;;
      *)
        echo "$me: downloading $name failed: $url ($detail); $unchanged." >&2
        exit 3 ;;
    esac
  fi
  if ! problem=$(check "$tmp/$name" "$sha" "$size"); then
    echo "$me: $name from $url is $problem; $unchanged." >&2
    exit 1
  fi
  say "  $name ok"
done

# python3's zipfile is always there (the project needs Debian's python); unzip often is not.
mkdir "$tmp/victoria_park_ascii"
if [[ -x /usr/bin/python3 ]]; then
  unpack=(/usr/bin/python3 -m zipfile -e "$tmp/victoria_park_ascii.zip" "$tmp/victoria_park_ascii")
elif command -v unzip > /dev/null; then
  unpack=(unzip -q -o "$tmp/victoria_park_ascii.zip" -d "$tmp/victoria_park_ascii")
else
  echo "$me: cannot unpack victoria_park_ascii.zip: neither /usr/bin/python3 nor unzip is installed; $unchanged." >&2
  exit 5
fi
if ! detail=$("${unpack[@]}" 2>&1); then
  echo "$me: victoria_park_ascii.zip did not unpack ($(tr '\n' ' ' <<< "$detail")); $unchanged." >&2
  exit 1
fi
for entry in "${unpacked[@]}"; do
  read -r name sha size <<< "$entry"
  if ! problem=$(check "$tmp/victoria_park_ascii/$name" "$sha" "$size"); then
    echo "$me: victoria_park_ascii/$name (from victoria_park_ascii.zip) is $problem; $unchanged." >&2
    exit 1
  fi
done
say "  victoria_park_ascii/ (5 files) ok"

# Everything verified: move file by file (renames, each one whole). aa3_dr.mat goes last: readers
# that test for it (demo.sh) then find the rest in place.
move() {
  mv -fT "$1" "$2" 2> /dev/null && return 0
  echo "$me: could not move ${2#"$VP_DATA"/} into $VP_DATA (is it a folder, or not writable?);" \
    "the files moved before it are complete and verified, run again once fixed." >&2
  exit 5
}
if ! mkdir -p "$VP_DATA/victoria_park_ascii" 2> /dev/null; then
  echo "$me: cannot create $VP_DATA/victoria_park_ascii/ (a file of that name?); $unchanged." >&2
  exit 5
fi
for entry in "${unpacked[@]}"; do
  read -r name sha size <<< "$entry"
  move "$tmp/victoria_park_ascii/$name" "$VP_DATA/victoria_park_ascii/$name"
done
for name in aa3_gpsx.mat lasersampling.txt victoria_park_ascii.zip aa3_dr.mat; do
  move "$tmp/$name" "$VP_DATA/$name"
done
finished=1
result "the Victoria Park data set is in $VP_DATA (9 files, sha256 verified)."
