// The habits of the repository, as tests: the tree is formatted with its own .clang-format,
// every repository path that a document or a comment cites exists, the nodelet plugin library
// carries on-vehicle code only (no simulator, evaluation, bag I/O or tool plumbing), no source
// file of src/, tools/, bench/ or include/ is longer than 1000 lines, no source folder holds more
// than 10 files and no table row of the docs is longer than 400 characters. (No function of src/,
// tools/ or bench/ is longer than 100 lines: clang-tidy's readability-function-size, configured
// in .clang-tidy and run by scripts/check_function_size.py, the test lint-function_size.)
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
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

/// Longest .cpp or .h file, in lines: a longer one holds more than one concern and is split by
/// them (issue 44). (The longest function, 100 lines, is clang-tidy's rule: .clang-tidy, checked by
/// scripts/check_function_size.py.)
constexpr std::size_t kMaxFileLines = 1000;

TEST(RepositoryRules, NoSourceFileIsLongerThan1000Lines)
{
  const auto files = repositoryFiles({"src", "tools", "bench", "include"}, {".h", ".cpp"});
  ASSERT_GT(files.size(), 100U);
  std::string long_files;
  for (const fs::path& file : files)
  {
    const std::string text = readFile(file);
    const auto lines = static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
    if (lines > kMaxFileLines)
    {
      long_files += "\n  " + fs::relative(file, kSource).string() + " (" + std::to_string(lines) + " lines)";
    }
  }
  EXPECT_TRUE(long_files.empty()) << "source files longer than " << kMaxFileLines
                                  << " lines: split each by concern into files of the same folder"
                                  << long_files;
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
