// DJNN: a held loop closure decided on the held scans (held_window_scans; docs/djnn.md, "Deciding
// a held closure on the held scans"). See djnn.h and held_window.h.
#include <algorithm>
#include <cmath>
#include <limits>
#include <tuple>

#include "ekf_slam/core/association/djnn/djnn.h"

namespace ekf_slam {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

// A held closure is retested at every scan with fresh observation noise on nearly the same prior:
// decided on the latest scan alone, one scan's noise eventually passes the margin, the wrong way
// as often as not when the scans tie. Each hypothesis of the current scan is weighed instead with
// the held scans' best explanation given it, in one joint Gaussian over the current filter (the
// prior counted once): cost(h) + sum over the held scans, newest first, of their pairings' cost
// given h and the scans before (each observation its cheapest option given them, one-to-one within
// its scan, or "not in the map").
void DJNN::heldWindowDecision(const AssociationContext& ctx, const AssociationContext& ectx,
                              const JointMlProblem& problem, JointMlDecision* d) {
  if (!d->complete) return;  // held anyway
  ++stats_.window_scans;
  const int m = static_cast<int>(problem.obs.size());
  const double null_cost = problem.null_cost;  // the uniform one: landmark + clutter density
  const EkfSlam& ekf = ctx.ekf();
  const std::vector<CarriedScan>& scans = held_window_.scans(ctx.robotPose());
  const int K = static_cast<int>(scans.size());

  // The held observations' options as weighed when they were held (landmarks, remembered and live
  // tentative features as virtual observations of their anchor), gated again on the current
  // filter; key: one-to-one within a scan.
  struct Option {
    WindowPairing p;
    std::int64_t key;
  };
  std::vector<std::vector<std::vector<Option>>> options(K);
  {
    const WindowLikelihood prior(ekf, ctx.model(), scans);
    for (int k = 0; k < K; ++k) {
      const std::vector<HeldWindow::Held>& held = held_window_.held(k);
      options[k].resize(held.size());
      for (std::size_t o = 0; o < held.size(); ++o) {
        for (const HeldWindow::Option& h : held[o].options) {
          const int j = ekf.indexOf(h.landmark);
          if (j < 0) continue;  // removed since
          const WindowPairing p{k, j, h.z.z, h.z.R, h.z.kind, h.cost};
          double mah = kInf;
          prior.conditionalCost(p, &mah);
          if (mah <= ambiguity_gate_) options[k][o].push_back({p, h.key});
        }
      }
    }
  }

  // The current scan's hypotheses: the best and each observation's best alternative.
  std::vector<std::vector<int>> hyps{d->best};
  for (const std::vector<int>& a : d->alternative) {
    if (!a.empty() && std::find(hyps.begin(), hyps.end(), a) == hyps.end()) hyps.push_back(a);
  }
  std::vector<double> total(hyps.size(), 0.0);
  for (std::size_t h = 0; h < hyps.size(); ++h) {
    WindowLikelihood w(ekf, ctx.model(), scans);
    double cost = 0.0;
    for (int k = 0; k < m && cost < kInf; ++k) {
      const int value = hyps[h][k];
      if (value == -1) {
        cost += null_cost;
        continue;
      }
      int obs = problem.obs[k], landmark = value;
      double charge = 0.0;
      if (value <= -2) {
        for (const JointMlExtra& e : problem.extra[k]) {
          if (e.target != -2 - value) continue;
          obs = e.obs;
          landmark = e.landmark;
          charge = e.cost;
        }
      }
      const Observation& z = ectx.observations()[obs];
      cost += w.add(WindowPairing{-1, landmark, z.z, z.R, z.kind, charge});
    }
    for (int k = K - 1; k >= 0 && cost < kInf; --k) {
      std::vector<std::tuple<double, int, int>> scored;  // cost given the pairings so far, obs, opt
      for (std::size_t o = 0; o < options[k].size(); ++o) {
        for (std::size_t q = 0; q < options[k][o].size(); ++q) {
          const double c = w.conditionalCost(options[k][o][q].p);
          if (c < null_cost) scored.emplace_back(c, static_cast<int>(o), static_cast<int>(q));
        }
      }
      std::sort(scored.begin(), scored.end());
      std::vector<char> done(options[k].size(), 0);
      std::vector<int> keys;
      int paired = 0;
      for (const auto& s : scored) {
        const Option& opt = options[k][std::get<1>(s)][std::get<2>(s)];
        if (done[std::get<1>(s)] || std::find(keys.begin(), keys.end(), opt.key) != keys.end()) {
          continue;
        }
        const double c = w.add(opt.p);
        if (!(c < kInf)) continue;
        done[std::get<1>(s)] = 1;
        keys.push_back(opt.key);
        cost += c;
        ++paired;
      }
      cost += null_cost * static_cast<double>(options[k].size() - paired);
    }
    total[h] = cost;
  }

  const std::size_t best =
      static_cast<std::size_t>(std::min_element(total.begin(), total.end()) - total.begin());
  if (!(total[best] < kInf)) return;
  d->best = hyps[best];
  d->best_cost = total[best];
  for (int k = 0; k < m; ++k) {
    d->alternative_cost[k] = kInf;
    for (std::size_t h = 0; h < hyps.size(); ++h) {
      if (hyps[h][k] != d->best[k]) {
        d->alternative_cost[k] = std::min(d->alternative_cost[k], total[h]);
      }
    }
  }
}

void DJNN::keepHeld(const AssociationContext& ctx, const AssociationContext& ectx,
                    const JointMlProblem& problem, const std::vector<int>& held) {
  if (held.empty()) {
    held_window_.clear();  // the closure is decided (or was never held)
    return;
  }
  std::vector<HeldWindow::Held> keep;
  for (int k : held) {
    HeldWindow::Held h;
    h.observation = ctx.observations()[problem.obs[k]];
    for (int j : problem.candidates[k]) {
      h.options.push_back({ctx.landmarkId(j), h.observation, 0.0, ctx.landmarkId(j)});
    }
    if (!problem.extra.empty()) {
      for (const JointMlExtra& e : problem.extra[k]) {
        // Keys of extras kept apart from landmark ids (>= 0).
        h.options.push_back({ctx.landmarkId(e.landmark), ectx.observations()[e.obs], e.cost,
                             -2 - static_cast<std::int64_t>(e.target)});
      }
    }
    keep.push_back(std::move(h));
  }
  held_window_.push(static_cast<std::uint32_t>(stats_.scans), ctx.robotPose(), keep);
}

}  // namespace ekf_slam
