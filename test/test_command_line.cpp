// CommandLine (app/command_line.h): the argument walker every program's parser uses.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "ekf_slam/app/command_line.h"

namespace ekf_slam {
namespace test_command_line {

// Parses --bag VALUE, --runs VALUE and --quiet the way the programs do; returns the error.
std::string parse(const std::vector<std::string>& args, std::string* bag, std::string* runs,
                  bool* quiet, bool* help) {
  CommandLine cl(args);
  while (cl.next()) {
    if (cl.is("--quiet")) {
      *quiet = true;
    } else if (cl.is("--bag")) {
      cl.value(bag);
    } else if (cl.is("--runs")) {
      std::string v;
      // The flag is still the flag once its value is taken.
      if (cl.value(&v) && (v.empty() || !cl.is("--runs"))) cl.fail("bad");
      if (v == "0") cl.fail(cl.flag() + " needs a positive integer, got '" + v + "'");
      *runs = v;
    } else {
      cl.unknown();
    }
  }
  *help = cl.help();
  return cl.error();
}

TEST(CommandLine, ReadsFlagsAndValues) {
  std::string bag, runs;
  bool quiet = false, help = false;
  EXPECT_EQ(parse({"--bag", "a.bag", "--quiet", "--runs", "3"}, &bag, &runs, &quiet, &help), "");
  EXPECT_EQ(bag, "a.bag");
  EXPECT_EQ(runs, "3");
  EXPECT_TRUE(quiet);
  EXPECT_FALSE(help);
  // A value may look like a flag: it is taken as the value.
  EXPECT_EQ(parse({"--bag", "--quiet"}, &bag, &runs, &quiet, &help), "");
  EXPECT_EQ(bag, "--quiet");
  EXPECT_EQ(parse({}, &bag, &runs, &quiet, &help), "");
}

TEST(CommandLine, ReportsTheFirstErrorAndStops) {
  std::string bag, runs;
  bool quiet = false, help = false;
  EXPECT_EQ(parse({"--bag"}, &bag, &runs, &quiet, &help), "--bag needs a value");
  EXPECT_EQ(parse({"--frob", "--bag"}, &bag, &runs, &quiet, &help), "unknown argument '--frob'");
  EXPECT_EQ(parse({"--runs", "0", "--frob"}, &bag, &runs, &quiet, &help),
            "--runs needs a positive integer, got '0'");
  // Nothing after the error is read: -h after it is not help.
  EXPECT_EQ(parse({"--frob", "-h"}, &bag, &runs, &quiet, &help), "unknown argument '--frob'");
  EXPECT_FALSE(help);
}

TEST(CommandLine, HelpStopsReading) {
  std::string bag, runs;
  bool quiet = false, help = false;
  EXPECT_EQ(parse({"--quiet", "-h", "--frob"}, &bag, &runs, &quiet, &help), "");
  EXPECT_TRUE(help);
  EXPECT_EQ(parse({"--help"}, &bag, &runs, &quiet, &help), "");
  EXPECT_TRUE(help);
}

}  // namespace test_command_line
}  // namespace ekf_slam
