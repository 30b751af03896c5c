// The tools' command lines, read with boost::program_options: long options as `--name VALUE` or
// `--name=VALUE`, short ones as `-c DIR` or `-cDIR`, switches without a value, `--` ending the
// options; no abbreviations. Every error is a UsageError whose message names the option or
// argument at fault, and a tool ends on it with usageFailure(): its name, the message, its own
// usage text (hand-written: program_options' generated help would lose its layout) and its exit
// status for usage errors.
#pragma once

#include <boost/program_options/options_description.hpp>
#include <boost/program_options/value_semantic.hpp>
#include <boost/program_options/variables_map.hpp>
#include <iostream>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace grid_vision_fusion
{
/// A command line a tool cannot run: what() names the option or the argument at fault.
class UsageError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// Reads argv[1 .. argc) against `options`: stores every value into the variable its option is
/// bound to (po::value(&variable)) and runs the notifiers. The arguments that are not options
/// (and all after `--`) are appended to `positional`; where it is null, they are an error.
/// @return what was given (count() tells whether an option was on the command line).
/// @throws UsageError: "unknown option --x", "missing the value of --x", "--x takes no value",
///         "--x is given more than once" (except an option of several values, std::vector),
///         "--x expects a number, got 'abc'", "--x expects an integer, got '2.5'", "--x: 'v'
///         is not a valid value", "unexpected argument 'foo'".
boost::program_options::variables_map parseCommandLine(
    int argc, const char* const argv[], const boost::program_options::options_description& options,
    std::vector<std::string>* positional = nullptr);

/// The end of a tool's main on a usage error: writes "<tool>: <message>", a blank line and
/// `usage` to stderr; returns `status` (the tool's exit status for usage errors).
int usageFailure(const std::string& tool, const std::string& message, const std::string& usage, int status);

/// The start of a tool's main: runs `parse`, which reads the command line and returns false when
/// --help was asked for, or throws UsageError. Returns the status the tool ends with now: 0 after
/// writing `usage` to stdout for --help, `usage_status` after usageFailure() for a usage error;
/// nothing when the tool goes on.
template <typename Parse>
std::optional<int> readCommandLine(const std::string& tool, const std::string& usage, int usage_status,
                                   Parse&& parse)
{
  try
  {
    if (parse())
    {
      return std::nullopt;
    }
    std::cout << usage;
    return 0;
  }
  catch (const UsageError& e)
  {
    return usageFailure(tool, e.what(), usage, usage_status);
  }
}

}  // namespace grid_vision_fusion
