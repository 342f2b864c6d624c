#include "ekf_slam/core/association/djnn/tentative_set.h"

#include <algorithm>
#include <cmath>

namespace ekf_slam {

namespace {

std::int64_t cellOf(double v, double cell) {
  const double c = std::floor(v / cell);
  if (!(c > -1.0e9)) return -1000000000LL;
  if (c > 1.0e9) return 1000000000LL;
  return static_cast<std::int64_t>(c);
}

std::int64_t packCell(std::int64_t ix, std::int64_t iy) {
  return static_cast<std::int64_t>((static_cast<std::uint64_t>(ix) << 32) ^
                                   (static_cast<std::uint64_t>(iy) & 0xffffffffULL));
}

}  // namespace

void TentativeSet::clear() {
  features_.clear();
  free_slots_.clear();
  cells_.clear();
  sweep_ = 0;
}

TentativeSet::CellKey TentativeSet::keyOf(const Eigen::Vector2d& p) const {
  return packCell(cellOf(p.x(), cell_), cellOf(p.y(), cell_));
}

int TentativeSet::add(const Eigen::Vector2d& position) {
  int slot;
  if (!free_slots_.empty()) {
    slot = free_slots_.back();
    free_slots_.pop_back();
  } else {
    slot = static_cast<int>(features_.size());
    features_.emplace_back();
  }
  Tentative& t = features_[slot];
  t.position = position;
  t.alive = true;
  cells_[keyOf(position)].push_back(slot);
  return slot;
}

void TentativeSet::unindex(int slot, CellKey key) {
  auto it = cells_.find(key);
  if (it == cells_.end()) return;
  std::vector<int>& v = it->second;
  auto pos = std::find(v.begin(), v.end(), slot);
  if (pos != v.end()) {
    *pos = v.back();
    v.pop_back();
  }
  if (v.empty()) cells_.erase(it);
}

void TentativeSet::remove(int slot) {
  Tentative& t = features_[slot];
  t.anchor = kNoLandmark;
  unindex(slot, keyOf(t.position));
  t.alive = false;
  free_slots_.push_back(slot);
}

void TentativeSet::move(int slot, const Eigen::Vector2d& position) {
  Tentative& t = features_[slot];
  const CellKey from = keyOf(t.position);
  const CellKey to = keyOf(position);
  t.position = position;
  if (from == to) return;
  unindex(slot, from);
  cells_[to].push_back(slot);
}

void TentativeSet::query(const Eigen::Vector2d& center, double radius,
                         std::vector<int>* out) const {
  out->clear();
  if (cells_.empty()) return;
  const std::int64_t x0 = cellOf(center.x() - radius, cell_);
  const std::int64_t x1 = cellOf(center.x() + radius, cell_);
  const std::int64_t y0 = cellOf(center.y() - radius, cell_);
  const std::int64_t y1 = cellOf(center.y() + radius, cell_);
  const double r2 = radius * radius;
  for (std::int64_t ix = x0; ix <= x1; ++ix) {
    for (std::int64_t iy = y0; iy <= y1; ++iy) {
      auto it = cells_.find(packCell(ix, iy));
      if (it == cells_.end()) continue;
      for (int slot : it->second) {
        if ((features_[slot].position - center).squaredNorm() < r2) out->push_back(slot);
      }
    }
  }
  std::sort(out->begin(), out->end());
}

int TentativeSet::nextSweepSlot() {
  sweep_ = (sweep_ + 1) % features_.size();
  return static_cast<int>(sweep_);
}

}  // namespace ekf_slam
