// Issue 13: every tool fails with a non-zero exit status and a message naming the file at fault,
// leaves no partial output (no .tmp) behind, and leaves an output already there intact. The
// inputs come from the tools themselves: a two-frame synthetic drive (make_synthetic_drive), its
// bag (kitti_to_bag), and that bag cut in half as a recording cut short leaves it.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <utility>

namespace
{
namespace fs = std::filesystem;

struct Result
{
  int status = 0;
  std::string output;  ///< stdout and stderr
};

Result run(const std::string& command)
{
  Result result;
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen((command + " 2>&1").c_str(), "r"), pclose);
  char buffer[512];
  while (pipe && std::fgets(buffer, sizeof(buffer), pipe.get()))
  {
    result.output += buffer;
  }
  result.status = pclose(pipe.release());
  return result;
}

std::string readFile(const fs::path& path)
{
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void writeFile(const fs::path& path, const std::string& text)
{
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

/// Paths under `dir` whose name holds ".tmp".
std::string temporariesUnder(const fs::path& dir)
{
  std::string found;
  for (const auto& entry : fs::recursive_directory_iterator(dir))
  {
    if (entry.path().filename().string().find(".tmp") != std::string::npos)
    {
      found += " " + entry.path().string();
    }
  }
  return found;
}

const std::string kPrecious = "an output of an earlier run\n";

class ToolErrors : public ::testing::Test
{
protected:
  static void SetUpTestSuite()
  {
    root_ = fs::path(testing::TempDir()) / "tool_errors";
    fs::remove_all(root_);
    fs::create_directories(root_);
    const Result drive = run(std::string(MAKE_SYNTHETIC_DRIVE) + " --output " + (root_ / "kitti").string() +
                             " --scenario " + GVF_SOURCE_DIR + "/test/data/kitti_replay_scenario.yaml" +
                             " --calibration " + GVF_SOURCE_DIR + "/data/calibration/2011_09_26 --frames 2");
    ASSERT_EQ(drive.status, 0) << drive.output;
    drive_ = root_ / "kitti" / "2011_09_26" / "2011_09_26_drive_9001_sync";
    full_bag_ = root_ / "full.bag";
    const Result bag =
        run(std::string(KITTI_TO_BAG) + " --quiet " + drive_.string() + " " + full_bag_.string());
    ASSERT_EQ(bag.status, 0) << bag.output;
    // The first half of the bag, as a recording cut short leaves it (no index at the end).
    half_bag_ = root_ / "half.bag";
    const std::string bytes = readFile(full_bag_);
    ASSERT_GT(bytes.size(), 1000U);
    writeFile(half_bag_, bytes.substr(0, bytes.size() / 2));
  }

  void SetUp() override
  {
    work_ = root_ / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::remove_all(work_);
    fs::create_directories(work_);
  }

  /// The checks every failure must pass.
  void expectCleanFailure(const Result& result, const std::string& named_file, const fs::path& kept_output)
  {
    EXPECT_NE(result.status, 0) << result.output;
    EXPECT_NE(result.output.find(named_file), std::string::npos)
        << "the message does not name " << named_file << ":\n"
        << result.output;
    EXPECT_EQ(temporariesUnder(work_), "") << "left behind";
    EXPECT_EQ(readFile(kept_output), kPrecious) << kept_output << " was changed";
  }

  static fs::path root_, drive_, full_bag_, half_bag_;
  fs::path work_;
};

fs::path ToolErrors::root_, ToolErrors::drive_, ToolErrors::full_bag_, ToolErrors::half_bag_;

std::string replayArgs(const fs::path& drive)
{
  return " --config-dir " GVF_SOURCE_DIR "/config --backend replay --replay-directory " +
         (drive / "label_2").string();
}

TEST_F(ToolErrors, RunPipelineNamesATruncatedBagAndSuggestsReindex)
{
  const fs::path output = work_ / "half_out.bag";
  writeFile(output, kPrecious);
  const Result result = run(std::string(RUN_PIPELINE) + " --bag " + half_bag_.string() + " --output " +
                            output.string() + replayArgs(drive_));
  expectCleanFailure(result, half_bag_.string(), output);
  EXPECT_NE(result.output.find("rosbag reindex " + half_bag_.string()), std::string::npos) << result.output;
}

TEST_F(ToolErrors, RunPipelineNamesAMissingBag)
{
  const fs::path output = work_ / "out.bag";
  writeFile(output, kPrecious);
  const fs::path missing = work_ / "missing.bag";
  const Result result = run(std::string(RUN_PIPELINE) + " --bag " + missing.string() + " --output " +
                            output.string() + replayArgs(drive_));
  expectCleanFailure(result, missing.string() + ": no such file", output);
}

TEST_F(ToolErrors, RunPipelineNamesAnUnwritableOutput)
{
  const fs::path kept = work_ / "kept.bag";
  writeFile(kept, kPrecious);
  const fs::path output = work_ / "no_such_folder" / "out.bag";
  const Result result = run(std::string(RUN_PIPELINE) + " --bag " + full_bag_.string() + " --output " +
                            output.string() + replayArgs(drive_));
  expectCleanFailure(result, output.string(), kept);
  EXPECT_FALSE(fs::exists(output.parent_path()));
}

TEST_F(ToolErrors, RunPipelineNamesABadParam)
{
  const fs::path output = work_ / "param_out.bag";
  writeFile(output, kPrecious);
  const std::string start = std::string(RUN_PIPELINE) + " --bag " + full_bag_.string() + " --output " +
                            output.string() + replayArgs(drive_);
  expectCleanFailure(run(start + " --param nowhere/threads=1"), "unknown node \"nowhere\"", output);
  expectCleanFailure(run(start + " --param threads=1"), "\"threads=1\" is not NODE/KEY=VALUE", output);
  // A value of the wrong type is refused by the node's table, which names the parameter.
  expectCleanFailure(run(start + " --param dynamic_grid/threads=many"), "threads", output);
}

TEST_F(ToolErrors, RunPipelineWithoutObjectsExitsThreeAndSaysWhy)
{
  const fs::path output = work_ / "out.bag";
  const Result result = run(std::string(RUN_PIPELINE) + " -q --bag " + full_bag_.string() + " --output " +
                            output.string() + replayArgs(drive_) + " --topics camera_info=/no_camera_info");
  EXPECT_EQ(WEXITSTATUS(result.status), 3) << result.output;
  EXPECT_NE(result.output.find("no object array came out of " + full_bag_.string()), std::string::npos)
      << result.output;
  EXPECT_NE(result.output.find("no camera_info on /no_camera_info"), std::string::npos) << result.output;
  EXPECT_TRUE(fs::exists(output)) << "the bag read is kept";
}

TEST_F(ToolErrors, RunPipelineQuietRunsWithoutProgress)
{
  const fs::path output = work_ / "out.bag";
  const Result result = run(std::string(RUN_PIPELINE) + " --quiet --bag " + full_bag_.string() +
                            " --output " + output.string() + replayArgs(drive_));
  EXPECT_EQ(result.status, 0) << result.output;
  EXPECT_EQ(result.output.find("messages: "), std::string::npos) << result.output;
  EXPECT_EQ(run(std::string(RUN_PIPELINE) + " -q --bag " + full_bag_.string() + " --output " +
                output.string() + replayArgs(drive_))
                .status,
            0);
}

TEST_F(ToolErrors, RunPipelineNamesTheModelOptionsTyped)
{
  const fs::path output = work_ / "out.bag";
  writeFile(output, kPrecious);
  const std::string start = std::string(RUN_PIPELINE) + " --bag " + full_bag_.string() + " --output " +
                            output.string() + " --config-dir " GVF_SOURCE_DIR "/config --backend opencv_dnn";
  expectCleanFailure(run(start + " --model /models/yolov3.cfg"), "give its .weights file with --weights",
                     output);
  expectCleanFailure(run(start + " --model m.onnx --weights m.weights"), "--weights m.weights is not used",
                     output);
}

TEST_F(ToolErrors, KittiToBagNamesAMissingDrive)
{
  const fs::path output = work_ / "out.bag";
  writeFile(output, kPrecious);
  const fs::path missing = work_ / "no_drive";
  const Result result =
      run(std::string(KITTI_TO_BAG) + " --quiet " + missing.string() + " " + output.string());
  expectCleanFailure(result, missing.string(), output);
}

TEST_F(ToolErrors, KittiToBagNamesACorruptScanAndRemovesThePartialBag)
{
  // A copy of the drive whose second scan is cut to 5 bytes: the bag is half written when the
  // conversion fails.
  const fs::path day = work_ / "2011_09_26";
  fs::copy(drive_.parent_path(), day, fs::copy_options::recursive);
  const fs::path drive = day / drive_.filename();
  const fs::path scan = drive / "velodyne_points" / "data" / "0000000001.bin";
  ASSERT_TRUE(fs::exists(scan));
  fs::resize_file(scan, 5);
  const fs::path output = work_ / "out.bag";
  writeFile(output, kPrecious);
  const Result result = run(std::string(KITTI_TO_BAG) + " --quiet " + drive.string() + " " + output.string());
  expectCleanFailure(result, scan.string(), output);
}

TEST_F(ToolErrors, EvaluateNamesATruncatedBag)
{
  const fs::path output = work_ / "evaluation";
  writeFile(output / "metrics.json", kPrecious);
  const Result result = run(std::string(EVALUATE) + " --drive " + drive_.string() + " --detections " +
                            half_bag_.string() + " --output " + output.string());
  expectCleanFailure(result, half_bag_.string(), output / "metrics.json");
  EXPECT_NE(result.output.find("rosbag reindex " + half_bag_.string()), std::string::npos) << result.output;
  EXPECT_EQ(std::distance(fs::directory_iterator(output), fs::directory_iterator()), 1) << "files added";
}

TEST_F(ToolErrors, EvaluateNamesAMissingDrive)
{
  const fs::path output = work_ / "evaluation";
  writeFile(output / "metrics.json", kPrecious);
  const fs::path missing = work_ / "no_drive";
  const Result result = run(std::string(EVALUATE) + " --drive " + missing.string() + " --detections " +
                            full_bag_.string() + " --output " + output.string());
  expectCleanFailure(result, missing.string(), output / "metrics.json");
}

TEST_F(ToolErrors, EvaluatePointsToLabelsForADriveWithoutTracklets)
{
  const fs::path drive = work_ / "2011_09_26" / drive_.filename();
  fs::copy(drive_.parent_path(), drive.parent_path(), fs::copy_options::recursive);
  fs::remove(drive / "tracklet_labels.xml");
  ASSERT_TRUE(fs::exists(drive / "label_2" / "0000000000.txt")) << "label files named like KITTI raw frames";
  const fs::path objects = work_ / "objects.bag";
  ASSERT_EQ(run(std::string(RUN_PIPELINE) + " -q --bag " + full_bag_.string() + " --output " +
                objects.string() + replayArgs(drive_))
                .status,
            0);
  const fs::path output = work_ / "evaluation";
  const std::string start = std::string(EVALUATE) + " --drive " + drive.string() + " --detections " +
                            objects.string() + " --output " + output.string();
  const Result result = run(start);
  EXPECT_NE(result.status, 0) << result.output;
  EXPECT_NE(result.output.find((drive / "tracklet_labels.xml").string() + ": no such file"),
            std::string::npos)
      << result.output;
  EXPECT_NE(result.output.find("--labels " + (drive / "label_2").string()), std::string::npos)
      << result.output;
  // The 10-digit label files are taken as frames (and then refused for their content: a drive's
  // label_2 lacks the motion column that --labels wants).
  const Result labelled = run(start + " --labels " + (drive / "label_2").string());
  EXPECT_EQ(labelled.output.find("no label files named"), std::string::npos) << labelled.output;
  EXPECT_NE(labelled.output.find("label_2/0000000000.txt:1: expected 15 KITTI fields"), std::string::npos)
      << labelled.output;
}

TEST_F(ToolErrors, EvaluateSaysWhyThereAreNoDetections)
{
  const fs::path output = work_ / "evaluation";
  // A bag without /objects (the sensor bag itself) is an error listing the bag's topics.
  Result result = run(std::string(EVALUATE) + " --drive " + drive_.string() + " --detections " +
                      full_bag_.string() + " --output " + output.string());
  EXPECT_NE(result.status, 0) << result.output;
  EXPECT_NE(result.output.find(full_bag_.string() + ": no message on topic /objects (topics: "),
            std::string::npos)
      << result.output;
  // Object arrays without an object (a replay of empty label files): a warning saying why.
  const fs::path empty_labels = work_ / "no_labels";
  fs::create_directories(empty_labels);
  const fs::path objects = work_ / "objects.bag";
  result =
      run(std::string(RUN_PIPELINE) + " -q --bag " + full_bag_.string() + " --output " + objects.string() +
          " --config-dir " GVF_SOURCE_DIR "/config --backend replay --replay-directory " +
          empty_labels.string() + " --param yolo_detector/replay/missing_file_is_empty=true");
  ASSERT_EQ(result.status, 0) << result.output;
  result = run(std::string(EVALUATE) + " --drive " + drive_.string() + " --detections " + objects.string() +
               " --output " + output.string());
  EXPECT_EQ(result.status, 0) << result.output;
  EXPECT_NE(
      result.output.find("messages on /objects hold no object, so every labelled object counts as missed"),
      std::string::npos)
      << result.output;
}

TEST_F(ToolErrors, MakeSyntheticDriveNamesAMissingScenario)
{
  const fs::path kept = work_ / "kitti" / "2011_09_26" / "2011_09_26_drive_9001_sync" / "marker.txt";
  writeFile(kept, kPrecious);
  const fs::path missing = work_ / "no_scenario.yaml";
  const Result result =
      run(std::string(MAKE_SYNTHETIC_DRIVE) + " --output " + (work_ / "kitti").string() + " --scenario " +
          missing.string() + " --calibration " + GVF_SOURCE_DIR + "/data/calibration/2011_09_26 --frames 2");
  expectCleanFailure(result, missing.string(), kept);
}

TEST_F(ToolErrors, MakeSyntheticDriveRemovesThePartialDrive)
{
  // The day folder's calibration file is a folder: copying the calibration fails after the drive
  // folders were created.
  const fs::path day = work_ / "kitti" / "2011_09_26";
  const fs::path kept = day / "2011_09_26_drive_9001_sync" / "marker.txt";
  writeFile(kept, kPrecious);
  fs::create_directories(day / "calib_cam_to_cam.txt");
  const Result result = run(std::string(MAKE_SYNTHETIC_DRIVE) + " --output " + (work_ / "kitti").string() +
                            " --scenario " + GVF_SOURCE_DIR + "/test/data/kitti_replay_scenario.yaml" +
                            " --calibration " + GVF_SOURCE_DIR + "/data/calibration/2011_09_26 --frames 2");
  expectCleanFailure(result, "calib_cam_to_cam.txt", kept);
  EXPECT_EQ(std::distance(fs::directory_iterator(kept.parent_path()), fs::directory_iterator()), 1)
      << "the earlier drive was changed";
}

TEST_F(ToolErrors, BagSummaryNamesATruncatedBag)
{
  const fs::path video = work_ / "overlay.avi";
  writeFile(video, kPrecious);
  const Result result = run(std::string(BAG_SUMMARY) + " --bag " + half_bag_.string() + " --video " +
                            video.string() + " --frames-dir " + (work_ / "frames").string());
  expectCleanFailure(result, half_bag_.string(), video);
  EXPECT_NE(result.output.find("rosbag reindex " + half_bag_.string()), std::string::npos) << result.output;
  EXPECT_FALSE(fs::exists(work_ / "frames"));
}

TEST_F(ToolErrors, BagSummaryNamesABagWithoutObjects)
{
  // The bag reads fine but holds no /objects: the frames exported so far must not stay.
  const fs::path video = work_ / "overlay.avi";
  writeFile(video, kPrecious);
  const Result result = run(std::string(BAG_SUMMARY) + " --bag " + full_bag_.string() +
                            " --images /kitti/camera_color_left/image_raw --video " + video.string() +
                            " --frames-dir " + (work_ / "frames").string());
  expectCleanFailure(result, full_bag_.string(), video);
  EXPECT_FALSE(fs::exists(work_ / "frames"));
}

TEST_F(ToolErrors, OptionsTakeTheirValueAfterAnEqualsSign)
{
  const Result result = run(std::string(MAKE_SYNTHETIC_DRIVE) + " --output=" + (work_ / "kitti").string() +
                            " --scenario=" + GVF_SOURCE_DIR + "/test/data/kitti_replay_scenario.yaml" +
                            " --calibration=" + GVF_SOURCE_DIR + "/data/calibration/2011_09_26 --frames=1");
  EXPECT_EQ(result.status, 0) << result.output;
  EXPECT_NE(result.output.find(": 1 frames"), std::string::npos) << result.output;
}

/// Every tool (boost::program_options through cli/command_line.h) names the option at fault, shows
/// its usage and exits with its status for usage errors.
TEST(ToolOptions, EveryToolNamesTheOptionAtFaultWithItsUsage)
{
  struct Tool
  {
    std::string path, name;
    int usage_status;
    std::string option_with_value;  ///< an option of the tool that takes a value
  };
  const Tool tools[] = {{BAG_SUMMARY, "bag_summary", 1, "--bag"},
                        {DETECT, "detect", 2, "--output"},
                        {EVALUATE, "evaluate", 2, "--output"},
                        {KITTI_TO_BAG, "kitti_to_bag", 2, "--calib"},
                        {LATENCY_PROBE, "latency_probe", 1, "--output"},
                        {MAKE_SYNTHETIC_DRIVE, "make_synthetic_drive", 1, "--output"},
                        {RUN_PIPELINE, "run_pipeline", 1, "--output"}};
  for (const Tool& tool : tools)
  {
    const std::string usage = "sage: " + tool.name;  // "usage:" or kitti_to_bag's "Usage:"
    const Result help = run(tool.path + " --help");
    EXPECT_EQ(WEXITSTATUS(help.status), 0) << help.output;
    EXPECT_NE(help.output.find(usage), std::string::npos) << help.output;
    EXPECT_EQ(WEXITSTATUS(run(tool.path + " -h").status), 0) << tool.name;
    for (const auto& [arguments, message] :
         {std::pair{std::string(" --bogus=1"), std::string("unknown option --bogus")},
          std::pair{" " + tool.option_with_value, "missing the value of " + tool.option_with_value},
          std::pair{" " + tool.option_with_value + " --help",
                    "missing the value of " + tool.option_with_value},
          std::pair{" " + tool.option_with_value + "=a " + tool.option_with_value + "=b",
                    tool.option_with_value + " is given more than once"},
          std::pair{std::string(" --help=yes"), std::string("--help takes no value")}})
    {
      const Result result = run(tool.path + arguments);
      EXPECT_EQ(WEXITSTATUS(result.status), tool.usage_status) << tool.name << arguments << "\n"
                                                               << result.output;
      EXPECT_NE(result.output.find(tool.name + ": " + message + "\n"), std::string::npos)
          << tool.name << arguments << "\n"
          << result.output;
      EXPECT_NE(result.output.find(usage), std::string::npos) << tool.name << arguments << "\n"
                                                              << result.output;
    }
  }
  // A value its option's type refuses.
  const Result number = run(std::string(EVALUATE) + " --drive d --detections b --output o --iou abc");
  EXPECT_EQ(WEXITSTATUS(number.status), 2) << number.output;
  EXPECT_NE(number.output.find("evaluate: --iou expects a number, got 'abc'"), std::string::npos)
      << number.output;
  const Result integer = run(std::string(MAKE_SYNTHETIC_DRIVE) + " --output o --frames 2.5");
  EXPECT_EQ(WEXITSTATUS(integer.status), 1) << integer.output;
  EXPECT_NE(integer.output.find("make_synthetic_drive: --frames expects an integer, got '2.5'"),
            std::string::npos)
      << integer.output;
  const Result seconds = run(std::string(RUN_PIPELINE) + " --bag b --output o --max-tf-wait=-1");
  EXPECT_EQ(WEXITSTATUS(seconds.status), 1) << seconds.output;
  EXPECT_NE(seconds.output.find("run_pipeline: --max-tf-wait needs seconds >= 0, got -1"), std::string::npos)
      << seconds.output;
  const Result stray = run(std::string(BAG_SUMMARY) + " --bag b.bag extra");
  EXPECT_EQ(WEXITSTATUS(stray.status), 1) << stray.output;
  EXPECT_NE(stray.output.find("bag_summary: unexpected argument 'extra'"), std::string::npos) << stray.output;
}

TEST(LatencyProbeErrors, NamesTheOptionOrTheFileAtFault)
{
  const std::string probe = LATENCY_PROBE;
  const Result unwritable = run(probe + " --output /nonexistent_gvf_dir/latencies.csv");
  EXPECT_EQ(WEXITSTATUS(unwritable.status), 1) << unwritable.output;
  EXPECT_NE(unwritable.output.find("cannot write --output /nonexistent_gvf_dir/latencies.csv"),
            std::string::npos)
      << unwritable.output;
  const Result missing = run(probe + " --output x.csv --objects");
  EXPECT_EQ(WEXITSTATUS(missing.status), 1) << missing.output;
  EXPECT_NE(missing.output.find("missing the value of --objects"), std::string::npos) << missing.output;
  const Result unknown = run(probe + " --outptu x.csv");
  EXPECT_EQ(WEXITSTATUS(unknown.status), 1) << unknown.output;
  EXPECT_NE(unknown.output.find("unknown option --outptu"), std::string::npos) << unknown.output;
  const Result none = run(probe);
  EXPECT_EQ(WEXITSTATUS(none.status), 1) << none.output;
  EXPECT_NE(none.output.find("give --output"), std::string::npos) << none.output;
}

}  // namespace
