// Deterministic mutation fuzz of association problems (issue 15): the example problems of
// test/data, mutated (numbers scaled, negated, zeroed, made huge or tiny; array entries
// dropped, duplicated or swapped; fields removed or given the wrong type; the text cut), then
// parsed and replayed with every associator. Each case must end as a clean ProblemError, or as a
// replay with valid indices (and a finite joint distance, or the command refuses it): no crash,
// no hang.
// EKF_SLAM_FUZZ_CASES sets the number of problems (default 3000, each with every associator;
// scripts/fuzz_replay.sh runs 10^5).
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "associators.h"
#include "ekf_slam/app/association_problem.h"
#include "ekf_slam/app/yaml_parameter_source.h"

namespace ekf_slam {
namespace test_replay_fuzz {

using Json = nlohmann::json;
const std::string kData = EKF_SLAM_TEST_DATA;

const std::vector<std::string> kAssociators = {"NN",     "JCBB",      "DJNN",
                                               "NNJCBB", "Hungarian", "RRWSC"};

// Every numeric leaf and every array of the document, by JSON pointer.
void collect(const Json& j, const Json::json_pointer& at, std::vector<Json::json_pointer>* numbers,
             std::vector<Json::json_pointer>* arrays) {
  if (j.is_number()) numbers->push_back(at);
  if (j.is_array()) {
    arrays->push_back(at);
    for (std::size_t i = 0; i < j.size(); ++i) collect(j[i], at / i, numbers, arrays);
  }
  if (j.is_object()) {
    for (const auto& item : j.items()) collect(item.value(), at / item.key(), numbers, arrays);
  }
}

// One to three mutations of `seed_doc`, drawn from `rng`; returns the text.
std::string mutate(Json doc, std::mt19937_64* rng) {
  std::uniform_int_distribution<int> count(1, 3);
  const int n = count(*rng);
  for (int k = 0; k < n; ++k) {
    std::vector<Json::json_pointer> numbers, arrays;
    collect(doc, Json::json_pointer(), &numbers, &arrays);
    const int what = std::uniform_int_distribution<int>(0, 9)(*rng);
    if (what <= 5 && !numbers.empty()) {
      Json& v = doc[numbers[(*rng)() % numbers.size()]];
      const double x = v.get<double>();
      const double values[] = {0.0,
                               -x,
                               x * 1e6,
                               x * 1e-6,
                               1e308,
                               -1e308,
                               1e-308,
                               x + 1.0,
                               x * (1.0 + 1e-3 * std::normal_distribution<double>()(*rng)),
                               static_cast<double>((*rng)() % 1000) - 500.0};
      v = values[(*rng)() % std::size(values)];
    } else if (what <= 7 && !arrays.empty()) {
      Json& a = doc[arrays[(*rng)() % arrays.size()]];
      if (a.empty()) continue;
      const std::size_t i = (*rng)() % a.size(), j = (*rng)() % a.size();
      switch ((*rng)() % 3) {
        case 0:
          a.erase(i);
          break;
        case 1:
          a.insert(a.begin() + static_cast<long>(i), a[i]);
          break;
        default:
          std::swap(a[i], a[j]);
      }
    } else if (what == 8 && doc.is_object() && !doc.empty()) {
      auto it = doc.begin();
      std::advance(it, static_cast<long>((*rng)() % doc.size()));
      if ((*rng)() % 2)
        doc.erase(it);
      else
        *it = (*rng)() % 2 ? Json("text") : Json(nullptr);
    } else {
      std::string text = doc.dump();
      text.resize((*rng)() % (text.size() + 1));  // cut anywhere
      return text;
    }
  }
  return doc.dump();
}

TEST(ReplayFuzz, MutatedProblemsGiveAnErrorOrAFiniteAnswer) {
  const char* env = std::getenv("EKF_SLAM_FUZZ_CASES");
  const long cases = env ? std::atol(env) : 3000;
  std::vector<Json> seeds;
  for (const char* name : {"clear.json", "shifted_row.json", "sensor_offset_wrap.json"}) {
    std::ifstream in(kData + "/" + name);
    seeds.push_back(Json::parse(in));
  }
  long rejected = 0, replayed = 0, refused = 0;  // refused: replay_association exits 1
  for (long c = 0; c < cases; ++c) {
    std::mt19937_64 rng(static_cast<std::uint64_t>(c));
    const std::string text = mutate(seeds[c % seeds.size()], &rng);
    AssociationProblem problem;
    try {
      problem = parseAssociationProblem(text, "case " + std::to_string(c));
    } catch (const ProblemError&) {
      ++rejected;
      continue;
    }
    const int landmarks = static_cast<int>((problem.state.size() - 3) / 2);
    for (const std::string& name : kAssociators) {
      SCOPED_TRACE("case " + std::to_string(c) + ", " + name + ": " + text);
      auto params = YamlParameterSource::fromString("", name);
      for (const auto& [k, v] : problemParameters(problem, name)) params.set(k, v);
      auto assoc = makeAssociator(name);
      ReplayResult r;
      try {
        assoc->configure(params);  // e.g. alpha 1e-308: probability 1 - alpha = 1 is refused
        r = replayAssociation(problem, *assoc);
      } catch (const std::exception& e) {
        ++refused;  // a clean error (replay_association exits 1 with it)
        continue;
      }
      ASSERT_EQ(r.landmark.size(), problem.observations.size());
      for (const int l : r.landmark) ASSERT_TRUE(l >= -1 && l < landmarks) << l;
      // Degenerate but valid problems (an R variance of 1e-308 with two observations paired to
      // one landmark) give a singular joint covariance: replay_association refuses to print the
      // infinite distance and exits 1 (ReplayAssociationCommand.FailsClearly).
      ++(std::isfinite(r.joint_mahalanobis) ? replayed : refused);
    }
  }
  std::cout << cases << " problems: " << rejected << " rejected by the parser, " << replayed
            << " finite replays, " << refused << " refused (an associator's error or a non-finite "
            << "distance)\n";
  EXPECT_GT(rejected, 0);
  EXPECT_GT(replayed, 0);
}

}  // namespace test_replay_fuzz
}  // namespace ekf_slam
