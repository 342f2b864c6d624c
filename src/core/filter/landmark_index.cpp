// Uniform grid over the landmark estimates, hashed by cell (see landmark_index.h).
#include "ekf_slam/core/filter/landmark_index.h"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace ekf_slam {

namespace {

// Cell coordinates are clamped so that a wild estimate (or a huge query) cannot overflow the
// 32-bit halves of the key; such cells are merely shared, and query() checks positions anyway.
constexpr double kMaxCell = 1.0e9;

std::int64_t cellCoordinate(double v, double cell) {
  const double c = std::floor(v / cell);
  if (!(c > -kMaxCell)) return static_cast<std::int64_t>(-kMaxCell);  // also NaN
  if (c > kMaxCell) return static_cast<std::int64_t>(kMaxCell);
  return static_cast<std::int64_t>(c);
}

void eraseFrom(std::vector<LandmarkId>* ids, LandmarkId id) {
  for (std::size_t k = 0; k < ids->size(); ++k) {
    if ((*ids)[k] == id) {
      (*ids)[k] = ids->back();  // order inside a cell does not matter
      ids->pop_back();
      return;
    }
  }
}

}  // namespace

LandmarkIndex::LandmarkIndex(double cell_size) : cell_(cell_size) {
  if (!(cell_size > 0.0) || !std::isfinite(cell_size)) {
    throw std::invalid_argument("LandmarkIndex: cell size must be positive and finite");
  }
}

LandmarkIndex::CellKey LandmarkIndex::key(std::int64_t ix, std::int64_t iy) {
  return static_cast<CellKey>((static_cast<std::uint64_t>(ix) << 32) ^
                              (static_cast<std::uint64_t>(iy) & 0xffffffffULL));
}

LandmarkIndex::CellKey LandmarkIndex::keyOf(const Eigen::Vector2d& p) const {
  return key(cellCoordinate(p.x(), cell_), cellCoordinate(p.y(), cell_));
}

void LandmarkIndex::clear() {
  cells_.clear();
  cell_of_.clear();
}

void LandmarkIndex::sync(const EkfSlam& ekf) {
  const std::vector<LandmarkId>& ids = ekf.landmarkIds();
  // Pass 1, O(n): insert new landmarks and re-bin those whose estimate left its cell.
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const LandmarkId id = ids[k];
    const CellKey cell = keyOf(ekf.landmark(static_cast<int>(k)));
    auto it = cell_of_.find(id);
    if (it == cell_of_.end()) {
      cell_of_.emplace(id, cell);
      cells_[cell].push_back(id);
    } else if (it->second != cell) {
      auto old = cells_.find(it->second);
      if (old != cells_.end()) {
        eraseFrom(&old->second, id);
        if (old->second.empty()) cells_.erase(old);
      }
      it->second = cell;
      cells_[cell].push_back(id);
    }
  }
  // Pass 2, only when something was removed (every map id is indexed now, so a surplus means
  // stale entries): drop ids the EKF no longer holds. O(n).
  if (cell_of_.size() == ids.size()) return;
  for (auto it = cell_of_.begin(); it != cell_of_.end();) {
    if (ekf.contains(it->first)) {
      ++it;
      continue;
    }
    auto cell = cells_.find(it->second);
    if (cell != cells_.end()) {
      eraseFrom(&cell->second, it->first);
      if (cell->second.empty()) cells_.erase(cell);
    }
    it = cell_of_.erase(it);
  }
}

void LandmarkIndex::query(const EkfSlam& ekf, const Eigen::Vector2d& center, double radius,
                          std::vector<int>* indices) const {
  if (!(radius >= 0.0) || cells_.empty()) return;
  const double r2 = radius * radius;
  auto visit = [&](const std::vector<LandmarkId>& ids) {
    for (LandmarkId id : ids) {
      const int index = ekf.indexOf(id);
      if (index < 0) continue;  // removed since the last sync
      if ((ekf.landmark(index) - center).squaredNorm() <= r2) indices->push_back(index);
    }
  };
  const std::int64_t x0 = cellCoordinate(center.x() - radius, cell_);
  const std::int64_t x1 = cellCoordinate(center.x() + radius, cell_);
  const std::int64_t y0 = cellCoordinate(center.y() - radius, cell_);
  const std::int64_t y1 = cellCoordinate(center.y() + radius, cell_);
  const double touched = static_cast<double>(x1 - x0 + 1) * static_cast<double>(y1 - y0 + 1);
  if (touched > static_cast<double>(cells_.size())) {
    // A disc larger than the occupied part of the map: walking the occupied cells is cheaper
    // than walking the empty ones, and just as exact.
    for (const auto& cell : cells_) visit(cell.second);
    return;
  }
  for (std::int64_t ix = x0; ix <= x1; ++ix) {
    for (std::int64_t iy = y0; iy <= y1; ++iy) {
      auto it = cells_.find(key(ix, iy));
      if (it != cells_.end()) visit(it->second);
    }
  }
}

}  // namespace ekf_slam
