// Capture folder version 3: frames listed in an append-only journal. What a reader sees
// before and after a commit, that the manifest no longer grows with the capture, that a
// line cut short is ignored, that recovery brings a crashed folder (built here by hand, and
// made by killing a writing process at random instants) back to exactly what it lists.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <thread>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "base/atomic_file.h"
#include "image/capture_folder.h"
#include "image/capture_folder_recovery.h"
#include "image/frame_journal.h"

extern char** environ;

namespace camlab::image {
namespace {

namespace fs = std::filesystem;

class CaptureJournalTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("camlab_journal_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  static FrameSidecar sidecar(uint64_t sequence) {
    FrameSidecar s;
    s.sequence = sequence;
    s.pixel_format = "Y12";
    s.bit_depth = 12;
    return s;
  }
  static cv::Mat frame(int value) { return cv::Mat(6, 8, CV_16UC1, cv::Scalar(value)); }

  std::set<std::string> files() const {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
    return names;
  }
  std::string journal() const { return *read_text_file(dir / kFrameJournalName); }

  fs::path dir;
};

TEST_F(CaptureJournalTest, AFrameIsListedOnlyOnceCommittedAndThenWhole) {
  auto writer =
      CaptureFolderWriter::create(dir, "single", {}, {}, CommitPolicy{100, std::chrono::hours(1)});
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  for (int k = 0; k < 3; ++k) ASSERT_TRUE(writer->add_frame(frame(100 + k), sidecar(k)).ok());
  EXPECT_EQ(writer->frame_count(), 3);
  EXPECT_EQ(writer->committed_count(), 0);
  ASSERT_TRUE(writer->commit_due().has_value());
  // Written, not yet listed: a reader sees no frame, and the files are there.
  EXPECT_EQ(CaptureFolder::open(dir)->frames().size(), 0u);
  EXPECT_TRUE(fs::exists(dir / "frame_000002.png"));

  ASSERT_TRUE(writer->commit().ok());
  EXPECT_FALSE(writer->commit_due().has_value());
  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok()) << folder.error().message;
  ASSERT_EQ(folder->frames().size(), 3u);
  EXPECT_FALSE(folder->complete());
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(folder->load_image(k)->at<uint16_t>(1, 1), 100 + k);
    EXPECT_EQ(folder->load_sidecar(k)->sequence, static_cast<uint64_t>(k));
  }
  // Each journal line says the sizes of the files it lists.
  const JournalContents lines = parse_frame_journal(journal());
  ASSERT_EQ(lines.entries.size(), 3u);
  EXPECT_EQ(lines.entries[1].image_bytes, fs::file_size(dir / "frame_000001.png"));
  EXPECT_EQ(lines.entries[1].sidecar_bytes, fs::file_size(dir / "frame_000001.json"));
}

TEST_F(CaptureJournalTest, ThePolicyCommitsByCountAndByAge) {
  auto writer =
      CaptureFolderWriter::create(dir, "single", {}, {}, CommitPolicy{4, std::chrono::hours(1)});
  ASSERT_TRUE(writer.ok());
  for (int k = 0; k < 9; ++k) ASSERT_TRUE(writer->add_frame(frame(k), sidecar(k)).ok());
  EXPECT_EQ(writer->committed_count(), 8) << "two commits of four";

  auto aged = CaptureFolderWriter::create(dir / "aged", "single", {}, {},
                                          CommitPolicy{100, std::chrono::milliseconds(0)});
  ASSERT_TRUE(aged.ok());
  ASSERT_TRUE(aged->add_frame(frame(1), sidecar(0)).ok());
  EXPECT_EQ(aged->committed_count(), 1) << "due at once";
}

TEST_F(CaptureJournalTest, TheManifestIsWrittenAtTheStartAndTheEndOnlyAndStaysSmall) {
  auto writer = CaptureFolderWriter::create(dir, "single", {{"backend", "test"}}, {},
                                            CommitPolicy{1, std::chrono::hours(1)});
  ASSERT_TRUE(writer.ok());
  const std::string at_start = *read_text_file(dir / "manifest.json");
  for (int k = 0; k < 12; ++k) ASSERT_TRUE(writer->add_frame(frame(k), sidecar(k)).ok());
  EXPECT_EQ(*read_text_file(dir / "manifest.json"), at_start) << "frames do not rewrite it";
  ASSERT_TRUE(writer->finish().ok());
  const std::string at_end = *read_text_file(dir / "manifest.json");
  EXPECT_LT(at_end.size(), at_start.size() + 64) << at_end;
  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok());
  EXPECT_TRUE(folder->complete());
  EXPECT_EQ(folder->manifest()["frame_count"], 12);
  EXPECT_EQ(folder->frames().size(), 12u);
  EXPECT_EQ(parse_frame_journal(journal()).entries.size(), 12u) << "one line per frame";
}

TEST_F(CaptureJournalTest, ALineCutShortIsIgnoredAndACompleteFolderMustListItsFrameCount) {
  {
    auto writer = CaptureFolderWriter::create(dir, "single", {}, {});
    ASSERT_TRUE(writer.ok());
    for (int k = 0; k < 2; ++k) ASSERT_TRUE(writer->add_frame(frame(k), sidecar(k)).ok());
  }  // dropped without finish: commits what it wrote
  std::ofstream(dir / kFrameJournalName, std::ios::app) << R"({"index":2,"image":"frame_0)";
  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok()) << folder.error().message;
  EXPECT_EQ(folder->frames().size(), 2u);
  EXPECT_NE(folder->journal_problem().find("line 3"), std::string::npos)
      << folder->journal_problem();

  // A manifest that says complete with 3 frames over a journal listing 2 is refused.
  nlohmann::json manifest = nlohmann::json::parse(*read_text_file(dir / "manifest.json"));
  manifest["complete"] = true;
  manifest["frame_count"] = 3;
  ASSERT_TRUE(write_file_atomically(dir / "manifest.json", manifest.dump()).ok());
  EXPECT_EQ(CaptureFolder::open(dir).error().code, ErrorCode::kBadManifest);

  // And a version 3 folder without its journal.
  fs::remove(dir / kFrameJournalName);
  EXPECT_EQ(CaptureFolder::open(dir).error().code, ErrorCode::kBadManifest);
}

TEST_F(CaptureJournalTest, JournalLinesThatAreNotFramesStopTheReading) {
  const std::string good =
      R"({"index":0,"image":"frame_000000.png","sidecar":"frame_000000.json","image_bytes":10,"sidecar_bytes":5})"
      "\n";
  EXPECT_EQ(parse_frame_journal(good).entries.size(), 1u);
  EXPECT_EQ(parse_frame_journal(good).ignored_bytes, 0u);
  for (const std::string bad : {
           R"({"index":1,"image":"a.png","sidecar":"a.json","image_bytes":1,"sidecar_bytes":1})",
           R"({"index":0,"image":"../x.png","sidecar":"a.json","image_bytes":1,"sidecar_bytes":1})",
           R"({"index":0,"image":"a.png","sidecar":"a.json","image_bytes":-1,"sidecar_bytes":1})",
           R"([0, "a.png"])",
           R"(not json)",
       }) {
    const JournalContents c = parse_frame_journal(bad + "\n" + good);
    EXPECT_EQ(c.entries.size(), 0u) << bad;
    EXPECT_EQ(c.valid_bytes, 0u) << bad;
    EXPECT_FALSE(c.problem.empty()) << bad;
  }
}

// A crash after frames were listed, with a frame written but not listed, a journal line cut
// short and a temporary manifest left behind (the states a kill leaves, made by hand).
TEST_F(CaptureJournalTest, RecoveryRemovesWhatIsNotListedAndCutsTheJournalToWholeLines) {
  {
    auto writer = CaptureFolderWriter::create(dir, "single", {}, {});
    ASSERT_TRUE(writer.ok());
    for (int k = 0; k < 3; ++k) ASSERT_TRUE(writer->add_frame(frame(k), sidecar(k)).ok());
  }
  cv::imwrite((dir / "frame_000003.png").string(), frame(3));
  std::ofstream(dir / "frame_000003.json") << "{\"sequence\": 3";  // cut short
  std::ofstream(dir / ".manifest.json.Xy12Ab") << "{";
  std::ofstream(dir / "notes.txt") << "a user's file";
  const size_t whole = journal().size();
  std::ofstream(dir / kFrameJournalName, std::ios::app) << R"({"index":3,"ima)";

  auto recovered = recover_capture_folder(dir);
  ASSERT_TRUE(recovered.ok()) << recovered.error().message;
  EXPECT_EQ(recovered->frames, 3);
  EXPECT_EQ(
      std::set<std::string>(recovered->removed.begin(), recovered->removed.end()),
      (std::set<std::string>{".manifest.json.Xy12Ab", "frame_000003.png", "frame_000003.json"}));
  EXPECT_GT(recovered->journal_bytes_cut, 0u);
  EXPECT_EQ(journal().size(), whole);
  std::set<std::string> expected = {"manifest.json", "frames.jsonl", "notes.txt"};
  for (int k = 0; k < 3; ++k) {
    expected.insert("frame_00000" + std::to_string(k) + ".png");
    expected.insert("frame_00000" + std::to_string(k) + ".json");
  }
  EXPECT_EQ(files(), expected);
  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok());
  EXPECT_TRUE(folder->journal_problem().empty());

  auto again = recover_capture_folder(dir);  // idempotent
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->frames, 3);
  EXPECT_TRUE(again->removed.empty());
  EXPECT_EQ(again->journal_bytes_cut, 0u);
}

// A filesystem that lost synced data (what the commit's order prevents) is still caught:
// the journal ends before the first frame whose files are shorter than it says.
TEST_F(CaptureJournalTest, RecoveryCutsTheJournalBeforeAFrameWhoseFilesAreShort) {
  {
    auto writer = CaptureFolderWriter::create(dir, "single", {}, {});
    ASSERT_TRUE(writer.ok());
    for (int k = 0; k < 4; ++k) ASSERT_TRUE(writer->add_frame(frame(k), sidecar(k)).ok());
  }
  fs::resize_file(dir / "frame_000002.png", 10);
  auto recovered = recover_capture_folder(dir);
  ASSERT_TRUE(recovered.ok()) << recovered.error().message;
  EXPECT_EQ(recovered->frames, 2);
  EXPECT_NE(recovered->journal_problem.find("frame 2"), std::string::npos);
  auto folder = CaptureFolder::open(dir);
  ASSERT_TRUE(folder.ok());
  EXPECT_EQ(folder->frames().size(), 2u);
  EXPECT_FALSE(fs::exists(dir / "frame_000003.png")) << "no longer listed, so removed";
}

TEST_F(CaptureJournalTest, RecoveryOfAVersionTwoFolderRemovesFramesItsManifestDoesNotList) {
  fs::create_directories(dir);
  cv::imwrite((dir / "frame_000000.png").string(), frame(5));
  std::ofstream(dir / "frame_000000.json") << R"({"sequence": 0, "timestamp_ns": 0,
    "bit_depth": 12, "settings": {}})";
  std::ofstream(dir / "manifest.json") << R"({"format": "camlab-capture", "version": 2,
    "kind": "single", "complete": false,
    "frames": [{"index": 0, "image": "frame_000000.png", "sidecar": "frame_000000.json"}]})";
  cv::imwrite((dir / "frame_000001.png").string(), frame(6));  // written, manifest not yet
  auto recovered = recover_capture_folder(dir);
  ASSERT_TRUE(recovered.ok()) << recovered.error().message;
  EXPECT_EQ(recovered->frames, 1);
  EXPECT_EQ(recovered->removed, std::vector<std::string>{"frame_000001.png"});
  EXPECT_EQ(CaptureFolder::open(dir)->load_image(0)->at<uint16_t>(0, 0), 5);
}

TEST_F(CaptureJournalTest, AFolderWithoutAManifestRecoversToNoFrames) {
  fs::create_directories(dir);
  std::ofstream(dir / ".manifest.json.abcDEF") << "{";
  auto recovered = recover_capture_folder(dir);
  ASSERT_TRUE(recovered.ok());
  EXPECT_EQ(recovered->frames, 0);
  EXPECT_TRUE(files().empty());
}

// The writer in another process, killed with SIGKILL at random instants: whatever the
// instant, the folder reads back consistent (every frame listed is whole and is the frame
// its index says), and recovery leaves exactly the listed files.
TEST_F(CaptureJournalTest, KilledAtRandomInstantsTheFolderListsOnlyWholeFrames) {
  std::mt19937 rng(20261125);
  // Each kill comes after a random number of frames were listed (so that most runs are
  // caught mid-capture whatever this machine's speed), then a random 0-15 ms more.
  std::uniform_int_distribution<int> listed_before_kill(0, 24), delay_ms(0, 15);
  int killed_with_frames = 0;
  for (int run = 0; run < 20; ++run) {
    const fs::path folder_dir = dir / ("run" + std::to_string(run));
    fs::create_directories(dir);
    std::string child = CAPTURE_WRITER_CHILD, path = folder_dir.string(), frames = "400";
    char* argv[] = {child.data(), path.data(), frames.data(), nullptr};
    pid_t pid = -1;
    ASSERT_EQ(posix_spawn(&pid, argv[0], nullptr, nullptr, argv, environ), 0);
    const size_t target = static_cast<size_t>(listed_before_kill(rng));
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
    int status = 0;
    while (std::chrono::steady_clock::now() < deadline && ::waitpid(pid, &status, WNOHANG) == 0) {
      auto text = read_text_file(folder_dir / kFrameJournalName);
      if (text && static_cast<size_t>(std::count(text->begin(), text->end(), '\n')) >= target)
        break;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms(rng)));
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);

    if (!fs::exists(folder_dir)) continue;  // killed before it made the folder
    const bool had_manifest = fs::exists(folder_dir / "manifest.json");
    size_t listed = 0;
    if (had_manifest) {
      auto folder = CaptureFolder::open(folder_dir);
      ASSERT_TRUE(folder.ok()) << "run " << run << ": " << folder.error().message;
      listed = folder->frames().size();
      for (size_t k = 0; k < listed; ++k) {
        const int index = static_cast<int>(k);
        auto image = folder->load_stored_image(index);
        ASSERT_TRUE(image.ok()) << "run " << run << " frame " << k << ": " << image.error().message;
        double lo = 0, hi = 0;
        cv::minMaxLoc(*image, &lo, &hi);
        EXPECT_GE(lo, 1000.0 * (k % 60)) << "run " << run << " frame " << k;
        EXPECT_LT(hi, 1000.0 * (k % 60) + 1000) << "run " << run << " frame " << k;
        auto side = folder->load_sidecar(index);
        ASSERT_TRUE(side.ok()) << "run " << run << " frame " << k << ": " << side.error().message;
        EXPECT_EQ(side->sequence, k);
      }
      killed_with_frames += listed > 0 && !folder->complete();
    }
    auto recovered = recover_capture_folder(folder_dir);
    ASSERT_TRUE(recovered.ok()) << recovered.error().message;
    EXPECT_EQ(static_cast<size_t>(recovered->frames), listed) << "run " << run;
    size_t others = 0, frame_files = 0;
    for (const auto& e : fs::directory_iterator(folder_dir)) {
      const std::string name = e.path().filename().string();
      EXPECT_NE(name[0], '.') << "run " << run << ": temporary " << name << " left";
      (name.rfind("frame_", 0) == 0 ? frame_files : others) += 1;
    }
    EXPECT_EQ(frame_files, 2 * listed) << "run " << run;
    EXPECT_LE(others, 2u) << "manifest.json and frames.jsonl";
  }
  // The instants must have caught captures in the middle, or the test proved little.
  EXPECT_GE(killed_with_frames, 10);
}

}  // namespace
}  // namespace camlab::image
