#!/usr/bin/env bash
# Behaviour identity: a fixed set of runs whose outputs, timings left out, must stay byte for
# byte the same through a change that is meant to change no behaviour (a refactoring; issue 32).
#
#   scripts/identity.sh record [--quick]   write the checksums to test/data/identity/
#   scripts/identity.sh check  [--quick]   rerun, compare; exit 1 naming every file that differs
#
# The runs (the full set, about 3 minutes on 2 cores; --quick, about 30 s, is what CI runs):
#   vp_DJNN       ekf_slam_offline on Victoria Park, DJNN, --smooth            (quick)
#   vp_JCBB       the same with JCBB
#   vp_cekf       DJNN with the compressed EKF (filter: cekf)
#   vp_kidnap     DJNN with FGCBB, kidnapped before scans 2000 and 4000       (quick)
#   eval_W        evaluate --runs 2 on djnn_strong, fiducials and rrw_kidnap_5 with every
#                 associator (fiducials: quick, DJNN only)
#   eval_reloc    evaluate --runs 2 on rrw_kidnap_5 and rrw_kidnap_10 with DJNN and FGCBB (quick)
#   eval_aekf     evaluate --runs 2 on aekf, truth and DJNN, speed_scale_yaw_bias
#   reloc_exp     relocalisation_experiment on Victoria Park (map 0:1000, test 1000:2500)
# Outputs stay in $EKF_SLAM_BUILD/identity/<run>/ (normalised copies in <run>/normalised/), so
# two commits can be diffed file by file. Needs the Victoria Park data ($VP_DATA) and a build.
set -eo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
source "$EKF_SLAM_DEVEL/setup.bash"

mode=${1:-}
quick=0
[[ ${2:-} == --quick ]] && quick=1
if [[ $mode != record && $mode != check ]]; then
  sed -n '2,20p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'
  exit 2
fi
ref_dir=$EKF_SLAM_ROOT/test/data/identity
ref=$ref_dir/$([[ $quick == 1 ]] && echo quick || echo full).sha256
out=$EKF_SLAM_BUILD/identity
rm -rf "$out"
mkdir -p "$out"

bag=${VP_BAG:-$EKF_SLAM_BUILD/vp.bag}
if [[ ! -f $bag ]]; then
  [[ -f $VP_DATA/aa3_dr.mat ]] || { echo "identity.sh: no Victoria Park data in $VP_DATA" >&2; exit 2; }
  rosrun ekf_slam victoria_park_to_bag --data "$VP_DATA" --out "$bag" > /dev/null
fi
vp_params=$EKF_SLAM_ROOT/config/victoria_park.yaml

offline() {  # offline NAME ARGS...
  local name=$1
  shift
  rosrun ekf_slam ekf_slam_offline --bag "$bag" --out "$out/$name" --no-plot --no-progress "$@" \
    > /dev/null 2> "$out/$name.log"
}
evaluate() {  # evaluate NAME ARGS...
  local name=$1
  shift
  rosrun ekf_slam evaluate --runs 2 --jobs 2 --no-progress --out "$out/$name" "$@" \
    > /dev/null 2> "$out/$name.log"
}
all=truth,ekf_slam/NN,ekf_slam/JCBB,ekf_slam/NNJCBB,ekf_slam/Hungarian,ekf_slam/RRWSC,ekf_slam/DJNN

offline vp_DJNN --params "$vp_params" --associator DJNN --smooth
offline vp_kidnap --params "$vp_params" --associator DJNN --relocaliser ekf_slam/FGCBB \
  --kidnap 2000:30,-20,1.5 --kidnap 4000:-15,10,-0.8
evaluate eval_reloc --world rrw_kidnap_5,rrw_kidnap_10 --associators ekf_slam/DJNN \
  --relocaliser ekf_slam/FGCBB
if [[ $quick == 1 ]]; then
  evaluate eval_fiducials --world fiducials --associators ekf_slam/DJNN
else
  offline vp_JCBB --params "$vp_params" --associator JCBB
  { cat "$vp_params"; echo "filter: cekf"; } > "$out/vp_cekf.yaml"
  offline vp_cekf --params "$out/vp_cekf.yaml" --associator DJNN
  for w in djnn_strong fiducials rrw_kidnap_5; do evaluate "eval_$w" --world $w --associators $all; done
  evaluate eval_aekf --world aekf --associators truth,ekf_slam/DJNN \
    --odometry-correction speed_scale_yaw_bias
  rosrun ekf_slam relocalisation_experiment --bag "$bag" --params "$vp_params" \
    --map-scans 0:1000 --test-scans 1000:2500 --relocaliser ekf_slam/FGCBB \
    --out "$out/reloc_exp" > /dev/null 2> "$out/reloc_exp.log"
fi

# Timings and paths differ from run to run: left out. CSV columns by name, JSON keys by name.
/usr/bin/python3 - "$out" <<'PY'
import csv, json, pathlib, re, sys
out = pathlib.Path(sys.argv[1])
timing = re.compile(r"(^|_)(time|wall|cpu|seconds|us|s)(_|$)|_us_|_s$|^write_s$|^bag$|^params$|^out$")
# Numbers to 9 significant digits: glibc picks exp/log/sin variants by CPU, whose last bits
# can differ between machines (eval_reloc's per-scan NEES did, with the same pairings and
# run results, 5 Dec 2026).
floating = re.compile(r"-?(\d+\.\d*|\.\d+|\d+(?=[eE]))([eE][-+]?\d+)?")
def num(text):
    return f"{float(text):.9g}" if floating.fullmatch(text) else text
def clean(o):
    if isinstance(o, dict):
        return {k: clean(v) for k, v in o.items() if not timing.search(k)}
    if isinstance(o, list):
        return [clean(v) for v in o]
    if isinstance(o, float):
        return float(f"{o:.9g}")
    return o
for run in sorted(p for p in out.iterdir() if p.is_dir()):
    norm = run / "normalised"
    norm.mkdir()
    for f in sorted(run.rglob("*")):
        if not f.is_file() or norm in f.parents or f.suffix in (".png", ".md", ".log"):
            continue
        rel = f.relative_to(run)
        dst = norm / str(rel).replace("/", "__")
        if f.suffix == ".json":
            dst.write_text(json.dumps(clean(json.loads(f.read_text())), indent=1, sort_keys=True) + "\n")
        elif f.suffix == ".csv":
            rows = list(csv.reader(f.read_text().splitlines()))
            keep = [i for i, h in enumerate(rows[0]) if not timing.search(h)] if rows else []
            dst.write_text("".join(",".join(num(r[i]) for i in keep if i < len(r)) + "\n" for r in rows))
        else:
            dst.write_bytes(f.read_bytes())
PY
sums=$(cd "$out" && find . -path '*/normalised/*' -type f | LC_ALL=C sort | xargs sha256sum)

if [[ $mode == record ]]; then
  mkdir -p "$ref_dir"
  { echo "# scripts/identity.sh record$([[ $quick == 1 ]] && echo ' --quick'): $(git -C "$EKF_SLAM_ROOT" rev-parse --short HEAD), $(date -u +%F)"
    echo "$sums"; } > "$ref"
  echo "recorded $(echo "$sums" | wc -l) files in $ref"
  exit 0
fi
[[ -f $ref ]] || { echo "identity.sh: no reference $ref (run: scripts/identity.sh record)" >&2; exit 2; }
if diff <(grep -v '^#' "$ref") <(echo "$sums") > "$out/diff.txt"; then
  echo "identity: $(echo "$sums" | wc -l) files identical to $(head -1 "$ref" | sed 's/^# //')"
  exit 0
fi
echo "identity: outputs differ from the reference ($(head -1 "$ref" | sed 's/^# //')):"
grep '^[<>]' "$out/diff.txt" | awk '{print $1, $3}' | sort -k2 | uniq
echo "(outputs in $out; record the reference's commit's outputs to diff them)"
exit 1
