// The offline runner's recovery options on simulated bags (written here, no data needed):
// --relocaliser on a kidnapped world, --kidnap on a world without one, map.txt written by every
// run and read back with --load-map --unknown-pose, and the argument parsing of the new options.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/ros/offline/offline_runner.h"
#include "ekf_slam/ros/plugin_loader.h"
#include "simulated_bag.h"

namespace ekf_slam {
namespace test_offline_recovery {

using test_files::SimulatedBag;

nlohmann::json metrics(const OfflineSummary& s) { return nlohmann::json::parse(s.metrics_json); }

// Distance between the final positions of two runs.
double finalDistance(const nlohmann::json& a, const nlohmann::json& b) {
  const double dx = a["final_pose"][0].get<double>() - b["final_pose"][0].get<double>();
  const double dy = a["final_pose"][1].get<double>() - b["final_pose"][1].get<double>();
  return std::hypot(dx, dy);
}

TEST(OfflineRecovery, KidnappedWorldIsRecoveredAndTheMapWritten) {
  const SimulatedBag bag("rrw_kidnap_6");
  OfflineOptions o = bag.options("run");
  o.relocaliser = "ekf_slam/FGCBB";
  std::ostringstream log;
  const OfflineSummary s = runOffline(o, log);
  const nlohmann::json j = metrics(s);
  EXPECT_EQ(j["relocaliser"], "FGCBB");
  EXPECT_GE(j["counters"]["lost_events"].get<int>(), 1) << log.str();
  EXPECT_GE(j["counters"]["relocalisations"].get<int>(), 1) << log.str();
  ASSERT_FALSE(j["relocalisation_events"].empty());
  EXPECT_FALSE(j["lost_at_end"].get<bool>());
  EXPECT_LT(j["truth"]["pose_rmse_m"].get<double>(), 5.0);
  EXPECT_EQ(j["truth"]["duplicates"].get<int>(), 0);
  EXPECT_NE(log.str().find("relocalised at scan"), std::string::npos) << log.str();
  // map.txt: the ~save_map format, every landmark of landmarks.csv.
  std::ifstream map(o.out_dir + "/map.txt");
  std::string header;
  std::getline(map, header);
  EXPECT_EQ(header, "ekf_slam_map 1");
}

// Recovery is on by default (issue 34); --relocaliser "" turns it off.
TEST(OfflineRecovery, TheKidnapIsRecoveredByDefaultNotWithRecoveryOff) {
  const SimulatedBag bag("rrw_kidnap_6");
  std::ostringstream log;
  OfflineOptions off = bag.options("off");
  off.relocaliser = "";
  const nlohmann::json j = metrics(runOffline(off, log));
  EXPECT_EQ(j["relocaliser"], "");
  EXPECT_EQ(j["counters"]["relocalisations"].get<int>(), 0);
  EXPECT_GT(j["truth"]["pose_rmse_m"].get<double>(), 5.0);
  const nlohmann::json on = metrics(runOffline(bag.options("on"), log));
  EXPECT_EQ(on["relocaliser"], "FGCBB");
  EXPECT_GE(on["counters"]["relocalisations"].get<int>(), 1);
  EXPECT_LT(on["truth"]["pose_rmse_m"].get<double>(), j["truth"]["pose_rmse_m"].get<double>());
}

TEST(OfflineRecovery, InjectedKidnapIsRecovered) {
  const SimulatedBag bag("rrw_noise_1");
  std::ostringstream plain_log;
  const nlohmann::json plain = metrics(runOffline(bag.options("plain"), plain_log));
  OfflineOptions o = bag.options("run");
  o.relocaliser = "FGCBB";
  o.kidnaps.push_back({300, Eigen::Vector3d(30.0, -20.0, 1.5)});
  std::ostringstream log;
  const nlohmann::json j = metrics(runOffline(o, log));
  EXPECT_NE(log.str().find("kidnap before scan 300"), std::string::npos) << log.str();
  EXPECT_EQ(j["counters"]["lost_events"].get<int>(), 1) << log.str();
  ASSERT_EQ(j["relocalisation_events"].size(), 1u) << log.str();
  const int scan = j["relocalisation_events"][0]["scan"].get<int>();
  EXPECT_GT(scan, 300);
  EXPECT_LE(scan, 310);  // within 2 s at 5 Hz
  // The run ends where the run without the kidnap ends.
  EXPECT_LT(finalDistance(j, plain), 1.0);
  // The scans processed while lost, and those tracked at the kidnapped pose before going lost,
  // are written with the poses re-derived from the fix: where the run without the kidnap had
  // them, not 36 m off.
  EXPECT_GE(j["counters"]["lost_path_poses"].get<int>(), 1);
  const std::size_t at = log.str().find("lost at scan ");
  ASSERT_NE(at, std::string::npos) << log.str();
  const int lost_scan = std::stoi(log.str().substr(at + 13));
  EXPECT_EQ(j["counters"]["rederived_tracked_poses"].get<int>(), lost_scan - 300);
  const double fix_stamp = j["relocalisation_events"][0]["stamp"].get<double>();
  const auto rows = [](const std::string& dir) {
    return test_files::positions(dir + "/trajectory.csv");
  };
  const auto kidnapped = rows(o.out_dir), reference = rows(bag.options("plain").out_dir);
  ASSERT_GT(kidnapped.size(), 300u);
  const double kidnap_stamp = std::next(kidnapped.begin(), 300)->first;  // row k: scan k
  int compared = 0;
  for (const auto& [t, p] : kidnapped) {
    if (t < kidnap_stamp || t > fix_stamp || !reference.count(t)) continue;
    EXPECT_LT((p - reference.at(t)).norm(), 1.0) << "stamp " << t;
    ++compared;
  }
  EXPECT_GE(compared, 2);
  EXPECT_EQ(j["truth"]["duplicates"].get<int>(), 0);
  // metrics.json lists the event: where it went lost, why, and the fix's correction, which
  // undoes the injected jump of 36 m and 1.5 rad (issue 34, item 4).
  ASSERT_EQ(j["lost_event_list"].size(), 1u) << j.dump(1);
  const nlohmann::json& e = j["lost_event_list"][0];
  EXPECT_EQ(e["scan"].get<int>(), lost_scan);
  EXPECT_FALSE(e["reason"].get<std::string>().empty());
  EXPECT_EQ(e["end"], "relocalised");
  EXPECT_EQ(e["end_scan"].get<int>(), scan);
  EXPECT_EQ(e["scans_lost"].get<int>(), scan - lost_scan);
  EXPECT_NEAR(e["correction_m"].get<double>(), std::hypot(30.0, 20.0), 3.0);
  EXPECT_NEAR(e["correction_rad"].get<double>(), -1.5, 0.1);
  EXPECT_GE(e["pairings"].get<int>(), 5);
  EXPECT_NE(log.str().find(" rad, "), std::string::npos) << log.str();
  // A run that never gets lost lists nothing (its metrics.json is the run's without recovery).
  EXPECT_FALSE(plain.contains("lost_event_list"));
}

TEST(OfflineRecovery, SavedMapWithUnknownPoseIsFoundAgain) {
  const SimulatedBag bag("rrw_noise_1");
  std::ostringstream log;
  OfflineOptions first = bag.options("first");
  const nlohmann::json built = metrics(runOffline(first, log));
  OfflineOptions second = bag.options("second");
  second.relocaliser = "FGCBB";
  second.load_map = first.out_dir + "/map.txt";
  second.unknown_pose = true;
  const nlohmann::json j = metrics(runOffline(second, log));
  ASSERT_GE(j["relocalisation_events"].size(), 1u) << log.str();
  EXPECT_LE(j["relocalisation_events"][0]["scan"].get<int>(), 3);  // within 0.6 s
  EXPECT_EQ(j["counters"]["relocalisation_requests"].get<int>(), 1);
  EXPECT_EQ(j["counters"]["relocalisations"].get<int>(), 1);
  // In the map of the first run, the second ends where the first did.
  EXPECT_LT(finalDistance(j, built), 1.0);
  // Unknown pose without a relocaliser, or without a map: clear errors.
  OfflineOptions bad = second;
  bad.relocaliser = "";  // off
  EXPECT_THROW(runOffline(bad, log), std::runtime_error);
  bad = second;
  bad.load_map.clear();
  EXPECT_THROW(runOffline(bad, log), std::runtime_error);
  bad = second;
  bad.relocaliser = "FGCB";
  EXPECT_THROW(runOffline(bad, log), UnknownRelocaliserError);
}

TEST(OfflineRecovery, ParsesTheRecoveryArguments) {
  OfflineOptions o;
  bool help = false;
  std::string error;
  ASSERT_TRUE(parseOfflineArguments(
      {"--bag", "b", "--out", "d", "--relocaliser", "FGCBB", "--load-map", "m.txt",
       "--unknown-pose", "--kidnap", "2000:30,-20,1.5", "--kidnap", "10:0,0,-0.5"},
      &o, &help, &error))
      << error;
  EXPECT_EQ(o.relocaliser, "FGCBB");
  EXPECT_EQ(o.load_map, "m.txt");
  // Unset: the YAML's, else the default; "" turns recovery off.
  OfflineOptions plain, off;
  ASSERT_TRUE(parseOfflineArguments({"--bag", "b", "--out", "d"}, &plain, &help, &error));
  EXPECT_FALSE(plain.relocaliser.has_value());
  ASSERT_TRUE(parseOfflineArguments({"--bag", "b", "--out", "d", "--relocaliser", ""}, &off, &help,
                                    &error));
  ASSERT_TRUE(off.relocaliser.has_value());
  EXPECT_EQ(*off.relocaliser, "");
  EXPECT_TRUE(o.unknown_pose);
  ASSERT_EQ(o.kidnaps.size(), 2u);
  EXPECT_EQ(o.kidnaps[0].scan, 2000u);
  EXPECT_TRUE(o.kidnaps[0].jump.isApprox(Eigen::Vector3d(30, -20, 1.5)));
  EXPECT_DOUBLE_EQ(o.kidnaps[1].jump.z(), -0.5);
  for (const std::string bad : {"2000", "2000:30,20", "x:1,2,3", "-1:1,2,3", "5:1,2,3junk"}) {
    OfflineOptions p;
    EXPECT_FALSE(
        parseOfflineArguments({"--bag", "b", "--out", "d", "--kidnap", bad}, &p, &help, &error))
        << bad;
    EXPECT_NE(error.find("--kidnap"), std::string::npos) << error;
  }
}

}  // namespace test_offline_recovery
}  // namespace ekf_slam
