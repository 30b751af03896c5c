// Fuzz harness: the label reader of the detection replay, DetectionReplay::detectionsOf() of a
// label file, and the replay's file pattern. The input: image width and height (uint16 each),
// default score and score threshold (one byte each, /255), a class map switch, the file pattern,
// then the label file.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "fuzz_input.h"
#include "grid_vision_fusion/detection/detection_replay.h"

namespace
{
/// A directory of its own for the label file, removed at exit.
struct LabelDirectory
{
  std::filesystem::path path;
  LabelDirectory()
  {
    std::string name = (std::filesystem::temp_directory_path() / "gvf_fuzz_replay_XXXXXX").string();
    if (mkdtemp(name.data()) == nullptr)
    {
      throw std::runtime_error("cannot create " + name);
    }
    path = name;
  }
  ~LabelDirectory()
  {
    std::error_code error;
    std::filesystem::remove_all(path, error);
  }
};
}  // namespace

GVF_FUZZ_TARGET(replay_labels)
{
  using namespace grid_vision_fusion;
  static const LabelDirectory directory;
  gvf_fuzz::ByteReader in(data, size);
  DetectionReplayConfig config;
  config.directory = directory.path.string();
  const auto width = in.take<std::uint16_t>();
  const auto height = in.take<std::uint16_t>();
  config.default_score = in.take<std::uint8_t>() / 255.0;
  config.score_threshold = in.take<std::uint8_t>() / 255.0;
  if (in.take<std::uint8_t>() % 2 == 1)
  {
    config.class_map = {{"Car", "car"}, {"Pedestrian", "person"}, {"Cyclist", "bicycle"}};
  }
  DetectionReplayConfig patterned = config;
  patterned.file_pattern = in.takeString(24);
  try
  {
    DetectionReplay(patterned).pathOf(in.take<std::int32_t>());
  }
  catch (const std::invalid_argument&)
  {
  }
  {
    const std::vector<std::uint8_t> labels = in.rest();
    std::ofstream file(directory.path / "000007.txt", std::ios::binary | std::ios::trunc);
    file.write(reinterpret_cast<const char*>(labels.data()), static_cast<std::streamsize>(labels.size()));
  }
  try
  {
    DetectionReplay(config).detectionsOf(7, width, height);
  }
  catch (const KittiLabelError&)
  {
  }
  return 0;
}
