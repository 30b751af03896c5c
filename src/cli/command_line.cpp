#include "grid_vision_fusion/cli/command_line.h"

#include <boost/program_options/errors.hpp>
#include <boost/program_options/parsers.hpp>
#include <iostream>

namespace po = boost::program_options;

namespace grid_vision_fusion
{
namespace
{
/// GNU style without abbreviations: --name VALUE, --name=VALUE, -c DIR, -cDIR, -qh.
constexpr int kStyle = po::command_line_style::default_style & ~po::command_line_style::allow_guessing;

/// "--name" of an option (its short form "-n" when it has no long name).
std::string displayName(const po::option_description& option)
{
  return option.canonical_display_name(po::command_line_style::allow_long);
}

template <typename... T>
bool holds(const po::value_semantic* semantic)
{
  return (... || (dynamic_cast<const po::typed_value<T>*>(semantic) != nullptr));
}

/// The UsageError of a value its option's type refuses: names the option, the type and the value.
UsageError valueError(const po::validation_error& error, const po::parsed_options& parsed,
                      const po::options_description& options)
{
  const std::string name = error.get_option_name();
  for (const po::option& given : parsed.options)
  {
    const po::option_description* option =
        given.string_key.empty() ? nullptr : options.find_nothrow(given.string_key, false);
    if (option == nullptr || displayName(*option) != name)
    {
      continue;
    }
    const std::string value = given.value.empty() ? std::string() : given.value.front();
    const po::value_semantic* semantic = option->semantic().get();
    if (holds<double, float>(semantic))
    {
      return UsageError(name + " expects a number, got '" + value + "'");
    }
    if (holds<int, long, long long, short>(semantic))
    {
      return UsageError(name + " expects an integer, got '" + value + "'");
    }
    return UsageError(name + ": '" + value + "' is not a valid value");
  }
  return UsageError(error.what());
}

/// Whether `token` (a value that followed its option) is itself an option of `options`: --name,
/// --name=VALUE or -n (a negative number is not).
bool namesAnOption(const std::string& token, const po::options_description& options)
{
  if (token.rfind("--", 0) == 0)
  {
    const std::string name = token.substr(2, token.find('=') - 2);
    return !name.empty() && options.find_nothrow(name, false) != nullptr;
  }
  if (token.size() < 2 || token[0] != '-')
  {
    return false;
  }
  for (const auto& option : options.options())
  {
    if (option->canonical_display_name(po::command_line_style::allow_dash_for_short) == token.substr(0, 2))
    {
      return true;
    }
  }
  return false;
}

/// program_options takes the token after an option as its value when it is not an option it knows
/// by that token; an option without its value, followed by another option, is an error here.
void checkValuesAreNoOptions(const po::parsed_options& parsed, const po::options_description& options)
{
  for (const po::option& given : parsed.options)
  {
    if (!given.string_key.empty() && given.original_tokens.size() > 1 &&
        namesAnOption(given.original_tokens.back(), options))
    {
      const po::option_description* option = options.find_nothrow(given.string_key, false);
      throw UsageError("missing the value of " +
                       (option ? displayName(*option) : given.original_tokens.front()));
    }
  }
}

po::parsed_options parseTokens(int argc, const char* const argv[], const po::options_description& options)
{
  try
  {
    return po::command_line_parser(argc, argv).options(options).style(kStyle).run();
  }
  catch (const po::unknown_option& e)
  {
    // The option as typed, without a value given as --name=VALUE.
    const std::string typed = e.get_option_name();
    throw UsageError("unknown option " +
                     typed.substr(0, typed.rfind("--", 0) == 0 ? typed.find('=') : typed.npos));
  }
  catch (const po::invalid_command_line_syntax& e)
  {
    switch (e.kind())
    {
      case po::invalid_syntax::missing_parameter:
      case po::invalid_syntax::empty_adjacent_parameter:
        throw UsageError("missing the value of " + e.get_option_name());
      case po::invalid_syntax::extra_parameter:
        throw UsageError(e.get_option_name() + " takes no value");
      default:
        throw UsageError(e.what());
    }
  }
  catch (const po::error& e)
  {
    throw UsageError(e.what());
  }
}
}  // namespace

po::variables_map parseCommandLine(int argc, const char* const argv[], const po::options_description& options,
                                   std::vector<std::string>* positional)
{
  const po::parsed_options parsed = parseTokens(argc, argv, options);
  checkValuesAreNoOptions(parsed, options);
  for (const po::option& given : parsed.options)
  {
    if (!given.string_key.empty())
    {
      continue;
    }
    const std::string argument = given.value.empty() ? std::string() : given.value.front();
    if (positional == nullptr)
    {
      throw UsageError("unexpected argument '" + argument + "'");
    }
    positional->push_back(argument);
  }
  po::variables_map given;
  try
  {
    po::store(parsed, given);
    po::notify(given);
  }
  catch (const po::multiple_occurrences& e)
  {
    throw UsageError(e.get_option_name() + " is given more than once");
  }
  catch (const po::validation_error& e)
  {
    throw valueError(e, parsed, options);
  }
  catch (const po::error& e)
  {
    throw UsageError(e.what());
  }
  return given;
}

int usageFailure(const std::string& tool, const std::string& message, const std::string& usage, int status)
{
  std::cerr << tool << ": " << message << "\n\n" << usage;
  return status;
}

}  // namespace grid_vision_fusion
