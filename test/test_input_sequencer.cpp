// InputSequencer: stamp ordering, ties, late items, latency release, flush, backwards jumps.
#include <gtest/gtest.h>

#include <algorithm>

#include <string>
#include <vector>

#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/pipeline/input_sequencer.h"

namespace ekf_slam {
namespace test_input_sequencer {

using Seq = InputSequencer<std::string>;

OdometryInput odom(double stamp) {
  OdometryInput o;
  o.stamp = stamp;
  return o;
}

// Drains the output as "o<stamp>", "s:<payload>", "J" (jump), with "!" for late items.
std::vector<std::string> drain(Seq* seq) {
  std::vector<std::string> out;
  Seq::Item item;
  while (seq->next(&item)) {
    std::string s;
    switch (item.kind) {
      case Seq::Kind::kOdometry: {
        char buf[32];
        std::snprintf(buf, sizeof(buf), "o%g", item.stamp);
        s = buf;
        break;
      }
      case Seq::Kind::kScan:
        s = "s:" + item.scan;
        break;
      case Seq::Kind::kTimeJump:
        s = "J";
        break;
      case Seq::Kind::kDropped:  // never handed out by InputSequencer
        s = "D";
        break;
    }
    if (item.late) s += "!";
    out.push_back(s);
  }
  return out;
}

using V = std::vector<std::string>;

TEST(InputSequencer, EachStreamWaitsForTheOtherToReachItsStamp) {
  Seq seq;
  EXPECT_EQ(seq.addOdometry(odom(1.0)), SequencerStatus::kQueued);
  EXPECT_TRUE(drain(&seq).empty());  // a scan stamped before 1.0 could still come
  EXPECT_EQ(seq.addScan(1.01, "a"), SequencerStatus::kQueued);
  EXPECT_EQ(drain(&seq), V({"o1"}));  // the scan waits for the odometry around it
  EXPECT_EQ(seq.pending(), 1u);
  seq.addOdometry(odom(1.025));
  EXPECT_EQ(drain(&seq), V({"s:a"}));
  seq.addScan(1.2, "b");
  EXPECT_EQ(drain(&seq), V({"o1.025"}));
}

TEST(InputSequencer, OutOfOrderArrivalsComeOutSorted) {
  Seq seq;
  seq.addScan(2.02, "b");
  seq.addScan(2.01, "a");  // arrives after b, older
  seq.addOdometry(odom(2.0));
  EXPECT_EQ(drain(&seq), V({"o2"}));
  seq.addOdometry(odom(2.05));
  EXPECT_EQ(drain(&seq), V({"s:a", "s:b"}));
  seq.flush();
  EXPECT_EQ(drain(&seq), V({"o2.05"}));
}

TEST(InputSequencer, OdometryBeforeScanAtTheSameStamp) {
  Seq seq;
  seq.addScan(3.0, "a");
  seq.addOdometry(odom(3.0));
  EXPECT_EQ(drain(&seq), V({"o3", "s:a"}));
  // A scan stamped exactly at the last released stamp is not late.
  EXPECT_EQ(seq.addScan(3.0, "b"), SequencerStatus::kQueued);
  seq.flush();
  EXPECT_EQ(drain(&seq), V({"s:b"}));
}

TEST(InputSequencer, LateItemsAreReleasedAtOnceAndFlagged) {
  Seq seq;
  seq.addOdometry(odom(5.0));
  seq.addScan(5.0, "a");
  EXPECT_EQ(drain(&seq), V({"o5", "s:a"}));
  EXPECT_EQ(seq.addOdometry(odom(4.9)), SequencerStatus::kLate);
  EXPECT_EQ(seq.addScan(4.95, "late"), SequencerStatus::kLate);
  EXPECT_EQ(drain(&seq), V({"o4.9!", "s:late!"}));
  EXPECT_EQ(seq.counters().late_odometry, 1u);
  EXPECT_EQ(seq.counters().late_scans, 1u);
}

TEST(InputSequencer, ItemsAreReleasedAfterMaxLatencyWhenAStreamStops) {
  InputSequencerConfig config;
  config.max_latency = 0.5;
  Seq seq(config);
  seq.addOdometry(odom(10.0));
  seq.addScan(10.0, "first");
  EXPECT_EQ(drain(&seq), V({"o10", "s:first"}));
  // Odometry stops: scans come out max_latency behind the newest stamp.
  seq.addScan(10.1, "a");
  seq.addScan(10.4, "b");
  EXPECT_TRUE(drain(&seq).empty());
  seq.addScan(10.7, "c");  // 10.1 < 10.7 - 0.5
  EXPECT_EQ(drain(&seq), V({"s:a"}));
  EXPECT_EQ(seq.counters().released_by_latency, 1u);
  seq.flush();  // end of input
  EXPECT_EQ(drain(&seq), V({"s:b", "s:c"}));
  EXPECT_EQ(seq.pending(), 0u);
  // The laser stops: odometry comes out max_latency behind.
  seq.addOdometry(odom(11.0));
  seq.addOdometry(odom(11.3));
  EXPECT_TRUE(drain(&seq).empty());
  seq.addOdometry(odom(11.6));
  EXPECT_EQ(drain(&seq), V({"o11"}));
}

TEST(InputSequencer, BackwardsJumpReleasesTheOldTimelineThenAMarker) {
  Seq seq;  // threshold 1 s
  seq.addOdometry(odom(100.0));
  seq.addScan(100.02, "old");
  EXPECT_EQ(drain(&seq), V({"o100"}));
  // Within the threshold: just late.
  EXPECT_EQ(seq.addOdometry(odom(99.5)), SequencerStatus::kLate);
  EXPECT_EQ(drain(&seq), V({"o99.5!"}));
  // Far back: held until the scans tell whether the whole input restarted; they do.
  EXPECT_EQ(seq.addOdometry(odom(0.0)), SequencerStatus::kHeld);
  EXPECT_TRUE(drain(&seq).empty());
  EXPECT_EQ(seq.addScan(0.01, "new"), SequencerStatus::kTimeJump);
  EXPECT_EQ(drain(&seq), V({"s:old", "J", "o0"}));
  EXPECT_EQ(seq.counters().time_jumps, 1u);
  // The new timeline works normally.
  seq.addOdometry(odom(0.025));
  EXPECT_EQ(drain(&seq), V({"s:new"}));
}

TEST(InputSequencer, ASingleStreamJumpingBackIsARestart) {
  Seq seq;  // odometry only: nothing else can confirm
  seq.addOdometry(odom(100.0));
  seq.addOdometry(odom(100.1));
  EXPECT_EQ(seq.addOdometry(odom(0.0)), SequencerStatus::kTimeJump);
  seq.flush();
  EXPECT_EQ(drain(&seq), V({"o100", "o100.1", "J", "o0"}));
}

// A bad publisher must not wipe the map: one stream alone cannot restart the timeline.
TEST(InputSequencer, OneStreamJumpingBackIsDroppedNotAReset) {
  Seq seq;
  for (int k = 0; k < 20; ++k) {
    seq.addOdometry(odom(100.0 + 0.1 * k));
    if (k % 2 == 1) seq.addScan(100.0 + 0.1 * k + 0.01, "s" + std::to_string(k));
  }
  drain(&seq);
  // Odometry 10 s back, while the scans go on: held, then refuted by the next scan.
  EXPECT_EQ(seq.addOdometry(odom(92.0)), SequencerStatus::kHeld);
  EXPECT_EQ(seq.addOdometry(odom(92.1)), SequencerStatus::kHeld);
  EXPECT_EQ(seq.addScan(102.05, "next"), SequencerStatus::kQueued);
  seq.addOdometry(odom(102.1));
  EXPECT_EQ(drain(&seq), V({"s:s19", "s:next"}));
  EXPECT_EQ(seq.counters().time_jumps, 0u);
  EXPECT_EQ(seq.counters().dropped_out_of_range, 2u);
  // The same for scans: their payloads are freed, nothing of them comes out.
  EXPECT_EQ(seq.addScan(50.0, "garbage"), SequencerStatus::kHeld);
  seq.addOdometry(odom(102.2));
  seq.addScan(102.25, "good");
  seq.addOdometry(odom(102.3));
  EXPECT_EQ(drain(&seq), V({"o102.1", "o102.2", "s:good"}));
  EXPECT_EQ(seq.counters().dropped_out_of_range, 3u);
  EXPECT_EQ(seq.counters().time_jumps, 0u);
}

TEST(InputSequencer, AScanFarInTheFutureDoesNotPoisonTheTimeline) {
  Seq seq;
  seq.addOdometry(odom(10.0));
  seq.addScan(10.05, "a");
  seq.addOdometry(odom(10.1));
  EXPECT_EQ(seq.addScan(1e9, "future"), SequencerStatus::kHeld);
  seq.addOdometry(odom(10.2));  // refutes it
  EXPECT_EQ(seq.addScan(10.25, "b"), SequencerStatus::kQueued);
  seq.addOdometry(odom(10.3));
  EXPECT_EQ(drain(&seq), V({"o10", "s:a", "o10.1", "o10.2", "s:b"}));
  EXPECT_EQ(seq.counters().time_jumps, 0u);
  EXPECT_EQ(seq.counters().dropped_out_of_range, 1u);
}

TEST(InputSequencer, BothStreamsJumpingBackIsARestart) {
  Seq seq;
  for (int k = 0; k < 10; ++k) {
    seq.addOdometry(odom(100.0 + 0.1 * k));
    seq.addScan(100.0 + 0.1 * k + 0.05, "old" + std::to_string(k));
  }
  drain(&seq);
  EXPECT_EQ(seq.addOdometry(odom(20.0)), SequencerStatus::kHeld);  // the bag starts again
  EXPECT_EQ(seq.addScan(20.05, "new"), SequencerStatus::kTimeJump);
  seq.addOdometry(odom(20.1));
  const V out = drain(&seq);
  ASSERT_FALSE(out.empty());
  const auto j = std::find(out.begin(), out.end(), "J");
  ASSERT_NE(j, out.end());
  EXPECT_EQ(V(j + 1, out.end()), V({"o20", "s:new"}));
  EXPECT_EQ(seq.counters().time_jumps, 1u);
  EXPECT_EQ(seq.counters().dropped_out_of_range, 0u);
}

TEST(InputSequencer, ScansDuringAnOdometryOutageAreKept) {
  // Odometry stops for 3 s (threshold 1 s) while scans go on, then resumes: every scan is used,
  // in stamp order, and nothing is a time jump.
  Seq seq;
  seq.addOdometry(odom(0.0));
  seq.addScan(0.05, "a");
  seq.addOdometry(odom(0.1));
  for (int k = 0; k < 15; ++k) seq.addScan(0.3 + 0.2 * k, "g" + std::to_string(k));
  seq.addOdometry(odom(3.2));
  seq.addScan(3.25, "b");
  seq.addOdometry(odom(3.3));
  const V out = drain(&seq);
  int scans = 0;
  for (const std::string& s : out) scans += s.rfind("s:", 0) == 0;
  EXPECT_EQ(scans, 17) << ::testing::PrintToString(out);
  EXPECT_EQ(seq.counters().time_jumps, 0u);
  EXPECT_EQ(seq.counters().dropped_out_of_range, 0u);
  EXPECT_EQ(out.back(), "s:b");
}

TEST(InputSequencer, NonFiniteStampsAreRejected) {
  Seq seq;
  EXPECT_EQ(seq.addOdometry(odom(std::nan(""))), SequencerStatus::kInvalidStamp);
  EXPECT_EQ(seq.addScan(INFINITY, "x"), SequencerStatus::kInvalidStamp);
  EXPECT_EQ(seq.counters().invalid_stamps, 2u);
  seq.flush();
  EXPECT_TRUE(drain(&seq).empty());
}

TEST(InputSequencer, InvalidConfigThrows) {
  InputSequencerConfig c;
  c.max_latency = -1.0;
  EXPECT_THROW(Seq{c}, ParameterError);
  c = InputSequencerConfig();
  c.time_jump_threshold = 0.0;
  EXPECT_THROW(Seq{c}, ParameterError);
}

TEST(InputSequencer, ReleasesEveryItemExactlyOnceInOrderForJitteredInput) {
  // Scans arrive 50 ms (two odometry periods) after odometry of the same time, as from a
  // laser driver with latency: output is sorted, complete, and nothing is late.
  Seq seq;
  std::vector<double> scan_stamps;
  for (int k = 0; k < 400; ++k) {
    seq.addOdometry(odom(k * 0.025));
    if (k % 5 == 2) {
      scan_stamps.push_back((k - 2) * 0.025 + 0.003);
      seq.addScan(scan_stamps.back(), std::to_string(scan_stamps.size() - 1));
    }
  }
  seq.flush();
  Seq::Item item;
  double last = -1.0;
  int odometry = 0, scans = 0;
  while (seq.next(&item)) {
    EXPECT_FALSE(item.late);
    EXPECT_GE(item.stamp, last);
    last = item.stamp;
    if (item.kind == Seq::Kind::kScan) {
      EXPECT_EQ(item.scan, std::to_string(scans));
      ++scans;
    } else {
      ++odometry;
    }
  }
  EXPECT_EQ(odometry, 400);
  EXPECT_EQ(scans, static_cast<int>(scan_stamps.size()));
}

}  // namespace test_input_sequencer
}  // namespace ekf_slam
