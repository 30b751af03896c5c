#include "grid_vision_fusion/cli/command_line.h"

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

namespace grid_vision_fusion
{
namespace
{
namespace po = boost::program_options;

/// A tool's options: a text, a number, an integer, a repeatable text, a switch with a short name.
struct Parsed
{
  std::string output;
  double tolerance = 0.5;
  int frames = -1;
  std::vector<std::string> params;
  bool quiet = false;
  std::vector<std::string> positional;
};

Parsed parse(std::vector<std::string> arguments, bool with_positional = true)
{
  Parsed p;
  po::options_description options;
  options.add_options()                       //
      ("output", po::value(&p.output))        //
      ("tolerance", po::value(&p.tolerance))  //
      ("frames", po::value(&p.frames))        //
      ("param", po::value(&p.params))         //
      ("quiet,q", po::bool_switch(&p.quiet));
  arguments.insert(arguments.begin(), "tool");
  std::vector<const char*> argv;
  for (const std::string& argument : arguments)
  {
    argv.push_back(argument.c_str());
  }
  parseCommandLine(static_cast<int>(argv.size()), argv.data(), options,
                   with_positional ? &p.positional : nullptr);
  return p;
}

/// The message of the UsageError that `arguments` raise ("" when none).
std::string errorOf(const std::vector<std::string>& arguments, bool with_positional = true)
{
  try
  {
    parse(arguments, with_positional);
  }
  catch (const UsageError& e)
  {
    return e.what();
  }
  return "";
}

TEST(CommandLine, ReadsValuesBothWaysSwitchesAndPositionalArguments)
{
  const Parsed p = parse({"--output", "out.bag", "--tolerance=0.25", "-q", "--frames", "-3", "--param", "a=1",
                          "drive", "--param=b=2", "--", "--not-an-option"});
  EXPECT_EQ(p.output, "out.bag");
  EXPECT_DOUBLE_EQ(p.tolerance, 0.25);
  EXPECT_EQ(p.frames, -3);
  EXPECT_TRUE(p.quiet);
  EXPECT_EQ(p.params, (std::vector<std::string>{"a=1", "b=2"}));
  EXPECT_EQ(p.positional, (std::vector<std::string>{"drive", "--not-an-option"}));
}

TEST(CommandLine, LeavesOptionsNotGivenAtTheirDefaults)
{
  const Parsed p = parse({});
  EXPECT_EQ(p.output, "");
  EXPECT_DOUBLE_EQ(p.tolerance, 0.5);
  EXPECT_EQ(p.frames, -1);
  EXPECT_FALSE(p.quiet);
}

TEST(CommandLine, ErrorsNameTheOptionAtFault)
{
  EXPECT_EQ(errorOf({"--outptu", "x"}), "unknown option --outptu");
  EXPECT_EQ(errorOf({"--outptu=x"}), "unknown option --outptu");
  EXPECT_EQ(errorOf({"--out", "x"}), "unknown option --out") << "no abbreviations";
  EXPECT_EQ(errorOf({"-x"}), "unknown option -x");
  EXPECT_EQ(errorOf({"--output"}), "missing the value of --output");
  EXPECT_EQ(errorOf({"--output="}), "missing the value of --output");
  EXPECT_EQ(errorOf({"--output", "--quiet"}), "missing the value of --output");
  EXPECT_EQ(errorOf({"--output", "-q"}), "missing the value of --output");
  EXPECT_EQ(errorOf({"--output", "--frames=2"}), "missing the value of --output");
  EXPECT_EQ(errorOf({"--quiet=yes"}), "--quiet takes no value");
  EXPECT_EQ(errorOf({"--output", "a", "--output", "b"}), "--output is given more than once");
  EXPECT_EQ(errorOf({"--tolerance", "abc"}), "--tolerance expects a number, got 'abc'");
  EXPECT_EQ(errorOf({"--tolerance", "0.5s"}), "--tolerance expects a number, got '0.5s'");
  EXPECT_EQ(errorOf({"--frames", "2.5"}), "--frames expects an integer, got '2.5'");
  EXPECT_EQ(errorOf({"stray"}, false), "unexpected argument 'stray'");
}

TEST(CommandLine, ReadCommandLineEndsTheToolOnHelpAndOnAUsageError)
{
  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(readCommandLine("tool", "USAGE\n", 7, [] { return false; }), std::optional<int>(0));
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "USAGE\n") << "--help: the usage on stdout";
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");

  testing::internal::CaptureStdout();
  testing::internal::CaptureStderr();
  EXPECT_EQ(readCommandLine("tool", "USAGE\n", 7, []() -> bool { throw UsageError("unknown option --x"); }),
            std::optional<int>(7));
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "");
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "tool: unknown option --x\n\nUSAGE\n");

  testing::internal::CaptureStdout();
  EXPECT_EQ(readCommandLine("tool", "USAGE\n", 7, [] { return true; }), std::nullopt) << "the tool goes on";
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "");
}

}  // namespace
}  // namespace grid_vision_fusion
