// An output of a tool (a file or a folder) written under a temporary name and moved to its
// final name only once complete, so that a failure leaves neither a partial output nor a
// `.tmp` behind, and an output already at the final name stays as it was. Shared by the tools
// and the libraries that write their outputs.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>

namespace grid_vision_fusion
{
class TemporaryOutput
{
public:
  /// Output `path`, written as `path` + `suffix` until commit(). Removes a stale temporary left
  /// by an earlier run that was killed.
  explicit TemporaryOutput(std::string path, const std::string& suffix = ".tmp")
      : path_(std::move(path)), temporary_(path_ + suffix)
  {
    remove();
  }
  /// Without commit(): removes the temporary file or folder.
  ~TemporaryOutput()
  {
    if (!committed_)
    {
      remove();
    }
  }
  TemporaryOutput(const TemporaryOutput&) = delete;
  TemporaryOutput& operator=(const TemporaryOutput&) = delete;

  /// Where to write.
  const std::string& temporary() const { return temporary_; }
  /// Where the output lands.
  const std::string& path() const { return path_; }

  /// Moves the temporary to path(). A temporary folder is merged into the folder at path()
  /// (created when missing): each of its entries replaces the entry of that name there, others
  /// stay. @throws std::runtime_error naming the paths when it cannot.
  void commit()
  {
    namespace fs = std::filesystem;
    std::error_code error;
    if (fs::is_directory(temporary_, error))
    {
      fs::create_directories(path_, error);
      if (error)
      {
        throw std::runtime_error("cannot create " + path_ + ": " + error.message());
      }
      for (const fs::directory_entry& entry : fs::directory_iterator(temporary_))
      {
        const fs::path target = fs::path(path_) / entry.path().filename();
        fs::remove_all(target, error);
        fs::rename(entry.path(), target, error);
        if (error)
        {
          throw std::runtime_error("cannot move " + entry.path().string() + " to " + target.string() + ": " +
                                   error.message());
        }
      }
      remove();
    }
    else
    {
      fs::rename(temporary_, path_, error);
      if (error)
      {
        throw std::runtime_error("cannot move " + temporary_ + " to " + path_ + ": " + error.message());
      }
    }
    committed_ = true;
  }

private:
  void remove() const
  {
    std::error_code ignored;
    std::filesystem::remove_all(temporary_, ignored);
  }

  std::string path_;
  std::string temporary_;
  bool committed_ = false;
};

}  // namespace grid_vision_fusion
