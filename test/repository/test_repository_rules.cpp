// The habits of the repository, as tests: the tree is formatted with its own .clang-format,
// every repository path that a document or a comment cites exists, the nodelet plugin library
// carries on-vehicle code only (no simulator, evaluation, bag I/O or tool plumbing), no function
// of the algorithms is longer than 100 lines and no source folder holds more than 10 files.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace
{
namespace fs = std::filesystem;
const fs::path kSource = GVF_SOURCE_DIR;

/// Output and exit status of a shell command.
struct CommandResult
{
  std::string output;
  int status = -1;
};

CommandResult runCommand(const std::string& command)
{
  CommandResult result;
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen((command + " 2>&1").c_str(), "r"), pclose);
  if (!pipe)
  {
    return result;
  }
  std::array<char, 4096> buffer{};
  std::size_t n = 0;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe.get())) > 0)
  {
    result.output.append(buffer.data(), n);
  }
  result.status = pclose(pipe.release());
  return result;
}

bool hasExtension(const fs::path& path, const std::set<std::string>& extensions)
{
  return extensions.count(path.extension().string()) > 0 || extensions.count(path.filename().string()) > 0;
}

/// The files of the repository under `folders` with one of `extensions` (or one of those file
/// names), build and data folders left out.
std::vector<fs::path> repositoryFiles(const std::vector<std::string>& folders,
                                      const std::set<std::string>& extensions)
{
  std::vector<fs::path> files;
  for (const std::string& folder : folders)
  {
    const fs::path root = kSource / folder;
    if (fs::is_regular_file(root) && hasExtension(root, extensions))
    {
      files.push_back(root);
      continue;
    }
    if (!fs::is_directory(root))
    {
      continue;
    }
    for (auto it = fs::recursive_directory_iterator(root); it != fs::recursive_directory_iterator(); ++it)
    {
      const std::string name = it->path().filename().string();
      if (it->is_directory() && (name == "data" || name == "build" || name == "devel" || name[0] == '.'))
      {
        it.disable_recursion_pending();
        continue;
      }
      if (it->is_regular_file() && hasExtension(it->path(), extensions))
      {
        files.push_back(it->path());
      }
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::string readFile(const fs::path& path)
{
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(RepositoryRules, TheSourcesAreFormattedWithTheRepositorysClangFormat)
{
  const std::string clang_format = GVF_CLANG_FORMAT;
  ASSERT_FALSE(clang_format.empty() || clang_format.find("NOTFOUND") != std::string::npos)
      << "clang-format is not installed (Debian: clang-format; scripts/install_deps.sh installs it)";
  std::vector<std::string> unformatted;
  const auto files = repositoryFiles({"include", "src", "test", "tools", "bench"}, {".h", ".cpp"});
  ASSERT_GT(files.size(), 50U);
  for (const fs::path& file : files)
  {
    const CommandResult r =
        runCommand("'" + clang_format + "' --style=file --dry-run -Werror '" + file.string() + "'");
    if (r.status != 0)
    {
      unformatted.push_back(fs::relative(file, kSource).string());
    }
  }
  EXPECT_TRUE(unformatted.empty()) << unformatted.size()
                                   << " file(s) differ from clang-format --style=file, e.g. "
                                   << unformatted.front()
                                   << "; run: git ls-files '*.h' '*.cpp' | xargs clang-format -i";
}

/// The text of `file` that may cite paths: the comments of C++ sources (not the #include lines,
/// which the compiler checks), the whole of any other file.
std::string citingText(const fs::path& file)
{
  const std::string text = readFile(file);
  if (!hasExtension(file, {".h", ".cpp"}))
  {
    return text;
  }
  std::string comments;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line))
  {
    const std::size_t comment = line.find("//");
    if (comment != std::string::npos && line.rfind("#include", 0) != 0)
    {
      comments += line.substr(comment + 2) + "\n";
    }
  }
  return comments;
}

/// The repository paths a text cites: words starting with one of the top folders, or naming a
/// document that lives outside the repository (the design notes, ../shared).
std::vector<std::string> citedPaths(const std::string& text)
{
  static const std::vector<std::string> kTop = {"doc/",    "src/",   "include/", "test/",    "config/",
                                                "launch/", "tools/", "bench/",   "cfg/",     "data/",
                                                "models/", "msg/",   "cmake/",   "scripts/", ".ci/"};
  static const std::string kDelimiters = " \t\n\"'`()[]<>,;|=";
  std::vector<std::string> out;
  std::size_t i = 0;
  while (i < text.size())
  {
    const std::size_t start = text.find_first_not_of(kDelimiters, i);
    if (start == std::string::npos)
    {
      break;
    }
    std::size_t end = text.find_first_of(kDelimiters, start);
    end = end == std::string::npos ? text.size() : end;
    std::string word = text.substr(start, end - start);
    i = end;
    if (word.find("DESIGN.md") != std::string::npos || word.find("STYLE.md") != std::string::npos ||
        word.find("../shared") != std::string::npos)
    {
      out.push_back(word);
      continue;
    }
    if (word.rfind("grid_vision_fusion/", 0) == 0 && word.size() > 2 && word.substr(word.size() - 2) == ".h")
    {
      word = "include/" + word;  // an include path
    }
    const bool top =
        std::any_of(kTop.begin(), kTop.end(), [&](const std::string& t) { return word.rfind(t, 0) == 0; });
    if (!top || word.find_first_of("{}$%<>") != std::string::npos)
    {
      continue;  // not a path, or a pattern such as doc/nodelets/<name>.md
    }
    word = word.substr(0, word.find('\\'));  // an escape in a string literal
    word = word.substr(0, word.find(':'));   // file:line
    word = word.substr(0, word.find('#'));   // file#anchor
    while (!word.empty() && (word.back() == '.' || word.back() == '/'))
    {
      word.pop_back();
    }
    out.push_back(word);
  }
  return out;
}

/// Whether the cited `path` exists (a trailing "*" matches any completion, "x.*" any extension).
bool exists(const std::string& path)
{
  const std::size_t star = path.find('*');
  if (star == std::string::npos)
  {
    return fs::exists(kSource / path);
  }
  const fs::path prefix = kSource / path.substr(0, star);
  const fs::path dir = prefix.parent_path();
  if (!fs::is_directory(dir))
  {
    return false;
  }
  const std::string stem = prefix.filename().string();
  for (const auto& entry : fs::directory_iterator(dir))
  {
    if (entry.path().filename().string().rfind(stem, 0) == 0)
    {
      return true;
    }
  }
  return false;
}

TEST(RepositoryRules, EveryCitedPathExists)
{
  const auto files = repositoryFiles(
      {"README.md", "doc", "include", "src", "test", "tools", "bench", "config", "launch", "cfg", "scripts",
       "cmake", "CMakeLists.txt", "msg", "package.xml", "nodelet_plugins.xml", ".ci"},
      {".md", ".h", ".cpp", ".yaml", ".launch", ".test", ".sh", ".py", ".cfg", ".cmake", ".msg", ".xml",
       "CMakeLists.txt", "run"});
  ASSERT_GT(files.size(), 100U);
  std::vector<std::string> dangling;
  for (const fs::path& file : files)
  {
    if (file.filename() == "test_repository_rules.cpp")
    {
      continue;  // names the forbidden citations itself
    }
    for (const std::string& path : citedPaths(citingText(file)))
    {
      const bool outside = path.find("DESIGN.md") != std::string::npos ||
                           path.find("STYLE.md") != std::string::npos ||
                           path.find("../shared") != std::string::npos;
      if (outside || !exists(path))
      {
        dangling.push_back(fs::relative(file, kSource).string() + ": " + path);
      }
    }
  }
  std::string list;
  for (const std::string& d : dangling)
  {
    list += "\n  " + d;
  }
  EXPECT_TRUE(dangling.empty()) << dangling.size()
                                << " cited path(s) do not exist in the repository:" << list;
}

TEST(RepositoryRules, ThePluginLibraryCarriesOnlyOnVehicleCode)
{
  const std::string plugin = GVF_PLUGIN_LIBRARY;
  const CommandResult ldd = runCommand("ldd '" + plugin + "'");
  ASSERT_EQ(ldd.status, 0) << ldd.output;
  for (const char* workshop : {"grid_vision_fusion_kitti", "grid_vision_fusion_evaluation",
                               "grid_vision_fusion_simulation", "grid_vision_fusion_offline", "librosbag"})
  {
    EXPECT_EQ(ldd.output.find(workshop), std::string::npos)
        << "the plugin library links " << workshop << ":\n"
        << ldd.output;
  }
  EXPECT_NE(ldd.output.find("grid_vision_fusion_core"), std::string::npos) << ldd.output;
  // The libraries it loads define no workshop code either.
  const fs::path dir = fs::path(plugin).parent_path();
  for (const char* library :
       {"libgrid_vision_fusion_nodelets.so", "libgrid_vision_fusion_ros.so", "libgrid_vision_fusion_core.so"})
  {
    const CommandResult nm = runCommand("nm -DC --defined-only '" + (dir / library).string() + "'");
    ASSERT_EQ(nm.status, 0) << nm.output;
    EXPECT_GT(nm.output.size(), 1000U) << library;
    for (const char* symbol : {"SceneSnapshot", "SyntheticScenario", "Pipeline", "KittiBag", "evaluate",
                               "ProgressBar", "KittiDrive"})
    {
      EXPECT_EQ(nm.output.find(symbol), std::string::npos) << library << " defines " << symbol;
    }
  }
}

/// `text` with its comments, string and character literals and preprocessor lines blanked out
/// (newlines kept, so that positions and line numbers stay), for counting braces.
std::string codeOnly(const std::string& text)
{
  std::string code = text;
  const std::size_t n = text.size();
  auto blank = [&](std::size_t begin, std::size_t end)
  {
    for (std::size_t k = begin; k < std::min(end, n); ++k)
    {
      code[k] = code[k] == '\n' ? '\n' : ' ';
    }
  };
  auto lineEnd = [&](std::size_t from)  // the end of a line, continued lines included
  {
    std::size_t end = text.find('\n', from);
    while (end != std::string::npos && end > 0 && text[end - 1] == '\\')
    {
      end = text.find('\n', end + 1);
    }
    return end == std::string::npos ? n : end;
  };
  std::size_t i = 0;
  while (i < n)
  {
    const std::size_t line = text.rfind('\n', i == 0 ? 0 : i - 1);
    const std::size_t line_begin = i == 0 || line == std::string::npos ? 0 : line + 1;
    const bool directive = text[i] == '#' && text.find_first_not_of(" \t", line_begin) == i;
    std::size_t end = i + 1;
    if (directive || text.compare(i, 2, "//") == 0)
    {
      end = lineEnd(i);
      blank(i, end);
    }
    else if (text.compare(i, 2, "/*") == 0)
    {
      const std::size_t close = text.find("*/", i + 2);
      end = close == std::string::npos ? n : close + 2;
      blank(i, end);
    }
    else if (text.compare(i, 2, "R\"") == 0 && text.find('(', i) != std::string::npos)
    {
      const std::size_t open = text.find('(', i);
      const std::size_t close = text.find(")" + text.substr(i + 2, open - i - 2) + "\"", open);
      end = close == std::string::npos ? n : close + open - i;
      blank(i + 1, end);
    }
    else if (text[i] == '"' ||
             (text[i] == '\'' && !(i > 0 && std::isxdigit(static_cast<unsigned char>(text[i - 1])))))
    {
      while (end < n && text[end] != text[i] && text[end] != '\n')  // (1'000: a digit separator)
      {
        end += text[end] == '\\' ? 2 : 1;
      }
      blank(i + 1, end);
      ++end;
    }
    i = end;
  }
  return code;
}

/// A function definition of a source file: its name and the lines from its head to its closing
/// brace.
struct FunctionSpan
{
  std::string name;
  std::size_t first_line = 0;
  std::size_t lines = 0;
};

/// Whether `head`, the code before a `{` since the last `;`, `{`, `}` or access label, opens a
/// function body: a parameter list, not after the keyword of a namespace, class, struct, union
/// or enum, and no initialiser (`= {`).
bool opensFunction(const std::string& head)
{
  const std::size_t paren = head.find('(');
  const std::size_t last = head.find_last_not_of(" \t\n");
  if (paren == std::string::npos || last == std::string::npos || head[last] == '=')
  {
    return false;
  }
  std::istringstream words(head.substr(0, paren));
  for (std::string word; words >> word;)
  {
    if (word == "namespace" || word == "class" || word == "struct" || word == "union" || word == "enum")
    {
      return false;
    }
  }
  return true;
}

/// The (qualified) name before the parameter list of a function head (attributes skipped).
std::string functionName(const std::string& head)
{
  std::size_t paren = head.find('(');
  while (paren != std::string::npos)
  {
    std::size_t end = paren;
    while (end > 0 && std::isspace(static_cast<unsigned char>(head[end - 1])))
    {
      --end;
    }
    std::size_t begin = end;
    while (begin > 0 && (std::isalnum(static_cast<unsigned char>(head[begin - 1])) ||
                         std::string("_:~").find(head[begin - 1]) != std::string::npos))
    {
      --begin;
    }
    const std::string name = head.substr(begin, end - begin);
    if (name != "__attribute__" && name != "alignas" && name != "__declspec")
    {
      return name;
    }
    int depth = 0;  // past the attribute's parentheses
    for (; paren < head.size(); ++paren)
    {
      depth += head[paren] == '(' ? 1 : head[paren] == ')' ? -1 : 0;
      if (depth == 0)
      {
        break;
      }
    }
    paren = head.find('(', paren);
  }
  return "";
}

/// Whether `text` is an access specifier (the words before the colon of `public:`).
bool isAccessLabel(const std::string& text)
{
  std::istringstream words(text);
  std::string word;
  std::string more;
  words >> word >> more;
  return more.empty() && (word == "public" || word == "protected" || word == "private");
}

/// The function definitions of the C++ source `text` at namespace or class scope (a lambda or a
/// local class is part of the function that holds it).
std::vector<FunctionSpan> functionSpans(const std::string& text)
{
  const std::string code = codeOnly(text);
  auto lineOf = [&](std::size_t pos)
  {
    return 1 + static_cast<std::size_t>(
                   std::count(code.begin(), code.begin() + static_cast<std::ptrdiff_t>(pos), '\n'));
  };
  struct Scope
  {
    bool function;
    std::size_t head;  // where the head of a function starts
    std::size_t brace;
  };
  std::vector<Scope> scopes;
  std::vector<FunctionSpan> spans;
  std::size_t statement = 0;  // where the code since the last `;`, `{`, `}` or access label starts
  for (std::size_t i = 0; i < code.size(); ++i)
  {
    const char c = code[i];
    if (c == '{')
    {
      const bool in_function =
          std::any_of(scopes.begin(), scopes.end(), [](const Scope& s) { return s.function; });
      const std::size_t head = std::min(code.find_first_not_of(" \t\n", statement), i);
      scopes.push_back({!in_function && opensFunction(code.substr(head, i - head)), head, i});
    }
    else if (c == '}' && !scopes.empty())
    {
      const Scope scope = scopes.back();
      scopes.pop_back();
      if (scope.function)
      {
        const std::size_t first = lineOf(scope.head);
        spans.push_back(
            {functionName(code.substr(scope.head, scope.brace - scope.head)), first, lineOf(i) - first + 1});
      }
    }
    if (c == '{' || c == '}' || c == ';' ||
        (c == ':' && isAccessLabel(code.substr(statement, i - statement))))
    {
      statement = i + 1;
    }
  }
  return spans;
}

TEST(RepositoryRules, TheFunctionScanMeasuresEveryDefinition)
{
  const std::string source = R"(// a { in a comment
#include <map>  // {
namespace ns
{
/* { */ const char* kText = "{ \" {";
const std::map<int, int> kTable = {{1, 2}};
struct Point
{
public:
  int sum() const
  {
    return x + y;
  }
  int x, y;
};
template <typename F>
void each(const F& f)
{
  auto g = [&](int k) { f(k); };
  g('{');
}
A::A(int v) : v_(v)
{
}
}  // namespace ns
)";
  const std::vector<FunctionSpan> spans = functionSpans(source);
  ASSERT_EQ(spans.size(), 3U);
  EXPECT_EQ(spans[0].name, "sum");
  EXPECT_EQ(spans[0].first_line, 10U);
  EXPECT_EQ(spans[0].lines, 4U);
  EXPECT_EQ(spans[1].name, "each");
  EXPECT_EQ(spans[1].first_line, 16U);
  EXPECT_EQ(spans[1].lines, 6U);
  EXPECT_EQ(spans[2].name, "A::A");
  EXPECT_EQ(spans[2].lines, 3U);
}

/// Longest function of the algorithms, head to closing brace: above it a function holds more
/// than one idea, and becomes a list of named steps (issue 27).
constexpr std::size_t kMaxFunctionLines = 100;

TEST(RepositoryRules, NoFunctionOfTheAlgorithmsIsLongerThan100Lines)
{
  // The exceptions, "<file>: <function>", each with its reason. (The Winograd micro-kernels of
  // src/detection/winograd_convolution.cpp, one unrolled transform each, would be one; they fit.)
  const std::set<std::string> allowed = {};
  const auto files = repositoryFiles({"src/grid", "src/fusion", "src/projection", "src/detection"}, {".cpp"});
  ASSERT_GT(files.size(), 10U);
  std::size_t functions = 0;
  std::set<std::string> found;
  std::string too_long;
  for (const fs::path& file : files)
  {
    const std::string path = fs::relative(file, kSource).string();
    for (const FunctionSpan& span : functionSpans(readFile(file)))
    {
      ++functions;
      const std::string id = path + ": " + span.name;
      found.insert(id);
      if (span.lines > kMaxFunctionLines && allowed.count(id) == 0)
      {
        too_long += "\n  " + path + ":" + std::to_string(span.first_line) + " " + span.name + " (" +
                    std::to_string(span.lines) + " lines)";
      }
    }
  }
  EXPECT_GT(functions, 200U);
  EXPECT_TRUE(too_long.empty()) << "functions longer than " << kMaxFunctionLines
                                << " lines: split them into named steps" << too_long;
  for (const std::string& id : allowed)
  {
    EXPECT_EQ(found.count(id), 1U) << "the allowed " << id << " is gone: take it off the list";
  }
}

/// Most .cpp/.h files one folder holds: a larger one is split by concern (issue 27).
constexpr std::size_t kMaxFolderFiles = 10;

TEST(RepositoryRules, NoSourceFolderHoldsMoreThan10Files)
{
  std::string crowded;
  std::size_t folders = 0;
  for (const std::string top : {"src", "include/grid_vision_fusion", "fuzz"})
  {
    std::vector<fs::path> dirs = {kSource / top};
    for (const auto& entry : fs::recursive_directory_iterator(kSource / top))
    {
      if (entry.is_directory())
      {
        dirs.push_back(entry.path());
      }
    }
    for (const fs::path& dir : dirs)
    {
      ++folders;
      const auto files = std::count_if(fs::directory_iterator(dir), fs::directory_iterator(),
                                       [](const fs::directory_entry& e) {
                                         return e.is_regular_file() && hasExtension(e.path(), {".cpp", ".h"});
                                       });
      if (static_cast<std::size_t>(files) > kMaxFolderFiles)
      {
        crowded += "\n  " + fs::relative(dir, kSource).string() + " (" + std::to_string(files) + " files)";
      }
    }
  }
  EXPECT_GT(folders, 20U);
  EXPECT_TRUE(crowded.empty()) << "folders with more than " << kMaxFolderFiles << " .cpp/.h files" << crowded;
}

/// Longest table row of the documentation, in characters: a row that grows past it has become
/// a lab notebook (every re-measurement appended to its cell; issue 27).
constexpr std::size_t kMaxTableRowCharacters = 400;

TEST(RepositoryRules, NoTableRowOfTheDocsIsLongerThan400Characters)
{
  const auto files = repositoryFiles({"README.md", "doc"}, {".md"});
  ASSERT_GT(files.size(), 10U);
  std::string long_rows;
  std::size_t rows = 0;
  for (const fs::path& file : files)
  {
    std::istringstream text(readFile(file));
    std::string line;
    for (std::size_t number = 1; std::getline(text, line); ++number)
    {
      if (line.rfind("|", 0) != 0)
      {
        continue;
      }
      ++rows;
      // Characters, not bytes: UTF-8 continuation bytes do not count.
      const auto characters = static_cast<std::size_t>(std::count_if(
          line.begin(), line.end(), [](char c) { return (static_cast<unsigned char>(c) & 0xC0) != 0x80; }));
      if (characters > kMaxTableRowCharacters)
      {
        long_rows += "\n  " + fs::relative(file, kSource).string() + ":" + std::to_string(number) + " (" +
                     std::to_string(characters) + " characters)";
      }
    }
  }
  EXPECT_GT(rows, 200U);
  EXPECT_TRUE(long_rows.empty()) << "table rows longer than " << kMaxTableRowCharacters
                                 << " characters: one figure per cell, the history in CHANGELOG.md"
                                 << long_rows;
}

}  // namespace
