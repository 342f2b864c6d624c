#!/usr/bin/python3
"""The include rule of docs/architecture.md: no include runs upward.

    scripts/check_layers.py [ROOT]      exit 1 and one line per violation, else a summary line

Layers (include/ekf_slam/<layer>/..., src/<layer>/...), each may include itself and those listed:
  core        Eigen only; inside it common < filter < feature_extraction, graph_matching
              < association < relocalisation < pipeline < smoothing (a folder includes its own
              and lower ones)
  data        nothing of ours
  app         core
  evaluation  core
  ros         core, app, data (+ messages); ros/node also ros; ros/plugins also ros;
              ros/offline also ros and evaluation (it scores simulated bags)
  tools       core, app, data, evaluation, ros
src/nodes (mains), bench and test may include anything.
"""
import pathlib
import re
import sys

CORE_RANK = {
    "common": 0,
    "filter": 1,
    "feature_extraction": 2,
    "graph_matching": 2,
    "association": 3,
    "relocalisation": 4,
    "pipeline": 5,
    "smoothing": 6,
}
ALLOWED = {
    "core": {"core"},
    "data": {"data"},
    "app": {"app", "core"},
    "evaluation": {"evaluation", "core"},
    "ros": {"ros", "core", "app", "data", "msgs"},
    "ros/node": {"ros", "ros/node", "core", "app", "data", "msgs"},
    "ros/plugins": {"ros", "ros/plugins", "core", "app", "data", "msgs"},
    "ros/offline": {"ros", "ros/offline", "core", "app", "data", "evaluation", "msgs"},
    "tools": {"tools", "core", "app", "data", "evaluation", "ros", "ros/offline", "msgs"},
}
INCLUDE = re.compile(r'^\s*#\s*include\s+"ekf_slam/([^"]+)"')


def unit(parts):
    """The layer of a path below include/ekf_slam or src, split into parts."""
    if parts[0] == "ros" and len(parts) > 2 and parts[1] in ("node", "plugins", "offline"):
        return "ros/" + parts[1]
    return parts[0]


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).parent.parent)
    bad, files = [], 0
    for base in (root / "include" / "ekf_slam", root / "src"):
        for path in sorted(base.rglob("*")):
            if path.suffix not in (".h", ".cpp"):
                continue
            parts = path.relative_to(base).parts
            if parts[0] == "nodes":
                continue
            files += 1
            layer = unit(parts)
            for number, line in enumerate(path.read_text().splitlines(), 1):
                m = INCLUDE.match(line)
                if not m:
                    continue
                target_parts = m.group(1).split("/")
                target = "msgs" if len(target_parts) == 1 else unit(target_parts)
                where = f"{path.relative_to(root)}:{number}: {layer} includes ekf_slam/{m.group(1)}"
                if target not in ALLOWED[layer]:
                    bad.append(f"{where} ({target} is not below {layer})")
                elif layer == "core" and target == "core":
                    here, there = CORE_RANK[parts[1]], CORE_RANK[target_parts[1]]
                    if there > here:
                        bad.append(f"{where} (core/{target_parts[1]} is above core/{parts[1]})")
    for b in bad:
        print(b)
    print(f"check_layers: {files} files, {len(bad)} includes against the rule")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
