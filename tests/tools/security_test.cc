// Issue 16, as a hostile user tried it: no shell between the command and another program, outputs
// that replace only regular files, no temporary left by an interrupt, and every numeric option
// bounded before any work. The command runs as a child process started with an argument vector
// (no shell in the test either, so the paths reach it byte for byte).
#include <fcntl.h>
#include <fmt/format.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli.h"
#include "output_file.h"

namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using ::testing::Not;

const std::string kModel = MJSTEPPER_SOURCE_DIR "/models/tsui_rigid.xml";

fs::path FreshDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("mjstepper_security_" + std::to_string(::getpid())) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// The mjstepper command as a child: argv as given, `path_env` as PATH when not empty, both output
// streams into `log` (a file: the test reads it after the child ends).
pid_t Start(const std::vector<std::string>& args, const fs::path& log,
            const std::string& path_env = "") {
  std::vector<std::string> argv = {MJSTEPPER_CLI};
  argv.insert(argv.end(), args.begin(), args.end());
  const pid_t pid = fork();
  if (pid == 0) {
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, 1);
    dup2(fd, 2);
    if (!path_env.empty()) setenv("PATH", path_env.c_str(), 1);
    std::vector<char*> raw;
    for (std::string& a : argv) raw.push_back(a.data());
    raw.push_back(nullptr);
    execv(raw[0], raw.data());
    _exit(127);
  }
  return pid;
}

struct Result {
  int status = -1;  // exit status, or 128 + signal
  std::string output;
};

Result Wait(pid_t pid, const fs::path& log) {
  int status = 0;
  waitpid(pid, &status, 0);
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), text.str()};
}

Result Cli(const std::vector<std::string>& args, const std::string& path_env = "") {
  const fs::path log = FreshDir("logs") / "out.txt";
  return Wait(Start(args, log, path_env), log);
}

std::vector<std::string> Entries(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  return names;
}

// Severe: `--render "o/x'; touch o/injected; echo '.mp4"` created o/injected through popen's shell.
// Now each path is one argument of a program started without a shell: no file appears, and the
// video is written under exactly the name given, quotes and all; so is "it's.mp4".
TEST(Security, RenderPathIsNeverParsedByAShell) {
  const fs::path dir = FreshDir("inject");
  const std::string hostile = (dir / "x'; touch INJECTED; echo '.mp4").string();
  const std::string apostrophe = (dir / "it's.mp4").string();
  for (const std::string& video : {hostile, apostrophe}) {
    const Result r =
        Cli({"run", kModel, "--duration", "0.05", "--size", "64x48", "--quiet", "--render", video});
    EXPECT_EQ(r.status, 0) << r.output;
    EXPECT_TRUE(fs::is_regular_file(video)) << video;
    EXPECT_GT(fs::file_size(video), 100u);
  }
  EXPECT_FALSE(fs::exists(dir / "INJECTED"));
  EXPECT_FALSE(fs::exists("INJECTED"));
  EXPECT_THAT(Entries(dir),
              ::testing::UnorderedElementsAre("x'; touch INJECTED; echo '.mp4", "it's.mp4"));
}

// Medium: without ffmpeg on PATH, --render died of SIGPIPE after the run ("sh: ffmpeg: not
// found", exit 141) and left FILE.csv.tmp. Now it fails before the run, naming ffmpeg and the
// package, and writes nothing.
TEST(Security, MissingFfmpegIsNamedBeforeTheRun) {
  const fs::path dir = FreshDir("noffmpeg");
  const Result r = Cli({"run", kModel, "--duration", "0.05", "--size", "64x48", "--quiet", "--log",
                        (dir / "run.csv").string(), "--render", (dir / "run.mp4").string()},
                       (dir / "empty_path").string());
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_THAT(r.output, AllOf(HasSubstr("ffmpeg"), HasSubstr("not on PATH"),
                              HasSubstr("apt-get install ffmpeg"), Not(HasSubstr("steps,"))));
  EXPECT_TRUE(Entries(dir).empty()) << ::testing::PrintToString(Entries(dir));
}

// Severe: --log /dev/null as root turned /dev/null into a CSV, and a symbolic link given as the log
// was replaced. Outputs now replace only regular files: a device, a FIFO, a symbolic link (even to
// a regular file) and a directory are refused before the run, naming the path, and left as they
// were; a regular file is replaced whole.
TEST(Security, OutputsReplaceOnlyRegularFiles) {
  const fs::path dir = FreshDir("targets");
  const fs::path fifo = dir / "fifo", link = dir / "link.csv", target = dir / "target.csv",
                 device = dir / "null", folder = dir / "folder";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0644), 0);
  std::ofstream(target) << "precious\n";
  fs::create_symlink(target, link);
  fs::create_directory(folder);
  std::vector<std::pair<fs::path, std::string>> refused = {
      {fifo, "a FIFO"}, {link, "a symbolic link"}, {folder, "a directory"}};
  // A character device of our own (1, 3: what /dev/null is), where we may make one (root).
  if (mknod(device.c_str(), S_IFCHR | 0666, makedev(1, 3)) == 0) {
    refused.emplace_back(device, "a character device");
  }
  for (const auto& [path, kind] : refused) {
    for (const char* option : {"--log", "--render"}) {
      const Result r = Cli({"run", kModel, "--duration", "0.05", "--size", "64x48", "--quiet",
                            option, path.string()});
      EXPECT_EQ(r.status, 1) << option << " " << path << ": " << r.output;
      EXPECT_THAT(r.output, AllOf(HasSubstr(path.string()), HasSubstr("it is " + kind),
                                  Not(HasSubstr("steps,"))));
    }
  }
  EXPECT_TRUE(fs::is_fifo(fifo));
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_TRUE(fs::is_directory(folder));
  if (fs::exists(device)) {
    EXPECT_TRUE(fs::is_character_file(device));
  }
  std::ifstream in(target);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "precious");  // the link's target is untouched
  // A regular file is replaced, and nothing else is left in the folder.
  const Result r = Cli({"run", kModel, "--duration", "0.05", "--quiet", "--log", target.string()});
  EXPECT_EQ(r.status, 0) << r.output;
  std::ifstream replaced(target);
  std::getline(replaced, line);
  EXPECT_THAT(line, HasSubstr("time[s]"));
  EXPECT_EQ(Entries(dir).size(), refused.size() + 1);
}

// Low: `--log X --render X` exited 0 and the summary said "log: X" while X held the video. Two
// outputs of one run may not share a file, however the path is spelled; nothing is written.
TEST(Security, TwoOutputsOfARunCannotShareAFile) {
  const fs::path dir = FreshDir("shared");
  const std::string x = (dir / "x").string(), same = (dir / "." / "x").string();
  for (const auto& [a, b] : std::vector<std::pair<std::string, std::string>>{
           {"--render", "--log"}, {"--plot", "--log"}, {"--frames", "--log"}}) {
    const Result r = Cli(
        {"run", kModel, "--duration", "0.05", "--size", "64x48", "--quiet", "--log", x, a, same});
    EXPECT_EQ(r.status, 1) << a << ": " << r.output;
    EXPECT_THAT(r.output, AllOf(HasSubstr("--log " + x), HasSubstr(a + " " + same),
                                HasSubstr("cannot be the same file")));
  }
  EXPECT_TRUE(Entries(dir).empty());
}

// Low: SIGINT or SIGTERM mid-run left FILE.tmp (or FILE.tmp.mp4). The interrupted command now
// removes its temporaries (and stops ffmpeg) and dies of the signal; no output appears.
TEST(Security, InterruptRemovesTemporaries) {
  for (int signal : {SIGINT, SIGTERM}) {
    const fs::path dir = FreshDir("interrupt" + std::to_string(signal));
    const fs::path log = dir.parent_path() / ("interrupt" + std::to_string(signal) + ".txt");
    const pid_t pid =
        Start({"run", kModel, "--duration", "100", "--size", "64x48", "--quiet", "--log",
               (dir / "run.csv").string(), "--render", (dir / "run.mp4").string()},
              log);
    // Wait until both temporaries exist (the run is under way), at most 20 s.
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (Entries(dir).size() < 2 && std::chrono::steady_clock::now() < give_up) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ASSERT_EQ(Entries(dir).size(), 2u) << "the run did not start";
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    kill(pid, signal);
    const Result r = Wait(pid, log);
    EXPECT_EQ(r.status, 128 + signal) << r.output;
    EXPECT_TRUE(Entries(dir).empty()) << ::testing::PrintToString(Entries(dir));
  }
}

// The OutputFile itself: nothing at the path until Commit, the usual mode after it, no
// temporary left by a destruction without Commit, and a target turned into a symbolic link while
// the file was written is refused at Commit (and left alone).
TEST(Security, OutputFileCommitsWholeOrNothing) {
  const fs::path dir = FreshDir("outputfile");
  const fs::path path = dir / "a.txt";
  {
    mjstepper::tools::OutputFile out(path.string());
    out.Write("abc", 3);
    EXPECT_FALSE(fs::exists(path));
    EXPECT_EQ(Entries(dir).size(), 1u);  // the temporary
  }
  EXPECT_TRUE(Entries(dir).empty());
  {
    const mode_t mask = umask(022);
    mjstepper::tools::OutputFile out(path.string());
    out.Write("abc", 3);
    out.Commit();
    umask(mask);
  }
  EXPECT_EQ(fs::file_size(path), 3u);
  EXPECT_EQ(fs::status(path).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read |
                fs::perms::others_read);
  {
    mjstepper::tools::OutputFile out(path.string());
    out.Write("defg", 4);
    fs::remove(path);
    fs::create_symlink("/dev/null", path);  // swapped in while the file was being written
    EXPECT_THROW(out.Commit(), std::runtime_error);
  }
  EXPECT_TRUE(fs::is_symlink(path));
  EXPECT_EQ(Entries(dir).size(), 1u);
}

// Medium and low: every numeric option has a range, and a value outside it is refused by the
// parser, naming the option and the range, before any work. (Cases from the issue.)
struct Refused {
  std::vector<std::string> args;
  std::string named;  // what the message must contain
};

std::string ParseError(std::vector<std::string> args) {
  args.insert(args.begin(), "mjstepper");
  std::vector<const char*> argv;
  for (const std::string& a : args) argv.push_back(a.c_str());
  mjstepper::tools::CommandLine cli;
  try {
    cli.Parse(static_cast<int>(argv.size()), argv.data());
  } catch (const CLI::ParseError& e) {
    return std::string("CLI11: ") + e.what();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(Security, EveryNumericOptionIsBoundedByTheParser) {
  const std::string frames = (fs::temp_directory_path() / "mjstepper_never_made").string();
  const std::vector<Refused> cases = {
      {{"run", kModel, "--duration", "1", "--frames", frames, "--fps", "1e300"},
       "--fps: 1e300 is not in [1, 1000] frames/s"},
      {{"run", kModel, "--duration", "1", "--frames", frames, "--playback", "1e-300"},
       "--playback: 1e-300 is not in [0.0001, 10000]"},
      {{"run", kModel, "--duration", "100", "--frames", frames, "--fps", "1000", "--playback",
        "0.001"},
       "--duration · --fps / --playback 100 s · 1000 /s / 0.001 = 1e+08 frames: must be in [1, "
       "1e+06] frames"},
      {{"run", kModel, "--duration", "1e300"}, "--duration: 1e300 is not in [1e-06, 1e+06] s"},
      {{"run", kModel, "--duration", "nan"}, "--duration: \"nan\" is not a finite number"},
      {{"run", kModel, "--duration", "1", "--size", "64x48abc"}, "--size 64x48abc: expected WxH"},
      {{"run", kModel, "--duration", "1", "--size", "8x48"}, "--size 8x48: must be in [16, 8192]"},
      {{"run", kModel, "--duration", "1", "--ctrl", "shaft=constant(1e12rpm)"},
       "--ctrl shaft=constant(1e12rpm): profile \"constant(1e12rpm)\": \"1e12rpm\" is beyond "
       "±10000 rad/s"},
      {{"run", kModel, "--duration", "1", "--log-every", "0"}, "--log-every: 0 is not in"},
      {{"run", kModel, "--duration", "1", "--mass", "payload=0"}, "--mass payload=0: must be in"},
      {{"sweep", kModel, "--speeds", "10rpm", "--out", "x", "--settle", "1e300"},
       "--settle: 1e300 is not in [0, 60] s"},
      {{"sweep", kModel, "--speeds", "10rpm", "--out", "x", "--measure", "1e-9"},
       "--measure: 1e-9 is not in [0.01, 60] s"},
      {{"sweep", kModel, "--speeds", "10rpm", "--out", "x", "--measure", "1e300"},
       "--measure: 1e300 is not in"},
      {{"sweep", kModel, "--speeds", "10:200:1e-9rpm", "--out", "x"},
       "--speeds 10:200:1e-9rpm (1.9e+11 speeds): must be in [1, 100000] speeds"},
      {{"sweep", kModel, "--speeds", "0:1e300:1rpm", "--out", "x"},
       "--speeds 0:1e300:1rpm (1e300rpm): must be in [-10000, 10000] rad/s"},
      {{"sweep", kModel, "--speeds", "10rpm", "--out", "x", "--threads", "-1"},
       "--threads: -1 is not in [0, 256]"},
      {{"map", kModel, "--speeds", "10rpm", "--out", "x", "--vary", "stiffness:j=-5"},
       "--vary stiffness:j=-5 (-5): must be in [0, 1e+12]"},
      {{"pullout", kModel, "--speeds", "10rpm", "--out", "x", "--rate", "1e-9"},
       "--rate: 1e-9 is not in [0.001, 10000] N·m/s"},
      {{"pullout", kModel, "--speeds", "10rpm", "--out", "x", "--rate", "0.001"},
       "--max-torque 5 / --rate 0.001 = 5000 s"},
      {{"identify", kModel, "--orders", "0"}, "--orders: 0 is not in [1, 64]"},
  };
  for (const Refused& c : cases) {
    EXPECT_THAT(ParseError(c.args), HasSubstr(c.named)) << ::testing::PrintToString(c.args);
  }
  EXPECT_FALSE(fs::exists(frames));  // parsing makes nothing
  // And the bounds are not so tight that ordinary commands fail.
  EXPECT_EQ(ParseError({"run", kModel, "--duration", "0.8", "--frames", frames, "--fps", "30",
                        "--playback", "0.1", "--size", "1280x720", "--ctrl",
                        "shaft=ramp(0rpm,200rpm,0.8s)"}),
            "");
  EXPECT_EQ(ParseError({"sweep", kModel, "--speeds", "10:200:2.5rpm", "--out", "x"}), "");
  EXPECT_EQ(ParseError({"identify", kModel, "--orders", "4", "2", "1"}), "");
}

// What needs the model, or belongs to the experiment (which Python binds too), is checked by the
// experiment, still before any step: a duration shorter than one timestep (it ran 0 steps and
// exited 0), a measured window under 100 timesteps, a harmonic order given twice.
TEST(Security, BoundsThatNeedTheModelFailBeforeAnyStep) {
  const fs::path dir = FreshDir("model_bounds");
  Result r =
      Cli({"run", kModel, "--duration", "1e-6", "--quiet", "--log", (dir / "a.csv").string()});
  EXPECT_EQ(r.status, 1);
  EXPECT_THAT(r.output, AllOf(HasSubstr("--duration 1e-06 (at the model's timestep 5e-05 s, 0 "
                                        "steps): must be in [1, 1e+12] steps"),
                              Not(HasSubstr("steps,"))));
  // The same motor at a 0.2 ms step (ωn·h = 0.18: fine for the rotor): 0.01 s is 50 steps.
  std::ifstream in(kModel);
  std::stringstream text;
  text << in.rdbuf();
  std::string model = text.str();
  const size_t at = model.find("timestep=\"");
  ASSERT_NE(at, std::string::npos);
  model.replace(at, model.find('"', at + 10) - at + 1, "timestep=\"0.0002\"");
  const fs::path coarse = dir.parent_path() / "coarse_step.xml";
  std::ofstream(coarse) << model;
  r = Cli({"sweep", coarse.string(), "--speeds", "10rpm", "--measure", "0.01", "--quiet", "--out",
           (dir / "s").string()});
  EXPECT_EQ(r.status, 1);
  EXPECT_THAT(r.output, HasSubstr("--measure 0.01: must hold at least 100 timesteps of the model "
                                  "(0.02 s)"));
  EXPECT_TRUE(Entries(dir).empty());
  // A keyframe whose time is NaN (MuJoCo reads time="nan") hung mj_step; the runner refuses it.
  std::string nan_key = text.str();
  nan_key.replace(nan_key.rfind("</mujoco>"), 9,
                  "<keyframe><key name=\"nan\" time=\"nan\" qpos=\"0\"/></keyframe></mujoco>");
  const fs::path nan_model = dir.parent_path() / "nan_keyframe.xml";
  std::ofstream(nan_model) << nan_key;
  r = Cli({"run", nan_model.string(), "--duration", "0.01", "--quiet", "--keyframe", "nan"});
  EXPECT_EQ(r.status, 1);
  EXPECT_THAT(r.output, HasSubstr("--keyframe nan: its time is nan s"));
  // identify --orders 4 4 fitted harmonic 4 twice (and --orders 0 printed a damping_detent the
  // plugin refuses: the parser's bound, above).
  r = Cli({"identify", MJSTEPPER_SOURCE_DIR "/models/tsui_identify.xml", "--orders", "4", "4"});
  EXPECT_EQ(r.status, 1);
  EXPECT_THAT(r.output,
              AllOf(HasSubstr("--orders: harmonic 4 is given twice"), Not(HasSubstr("Kd4"))));
}

}  // namespace

namespace {

// Issue 33: a speed list of the documented maximum, 1e5 numbers (2 MB of text), parses (each
// number's bound check formatted a message quoting the whole list: quadratic, minutes; the time is
// not asserted here), and a message about a long list quotes a bounded excerpt of it.
TEST(Security, ALongSpeedListParsesAndItsMessagesQuoteAnExcerpt) {
  std::string text;
  for (int k = 0; k < 100000; ++k) text += fmt::format("{}{:.17g}", k ? "," : "", 1 + k * 1e-5);
  const std::vector<double> speeds = mjstepper::tools::ParseSpeedList(text + "rad/s");
  ASSERT_EQ(speeds.size(), 100000u);
  EXPECT_EQ(speeds.back(), 1 + 99999 * 1e-5);
  for (const std::string& bad : {text + ",nope" + "rad/s", text + ",1e9rad/s", text + ",1rad/s"}) {
    try {
      mjstepper::tools::ParseSpeedList(bad);
      ADD_FAILURE() << "accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_LT(std::string(e.what()).size(), 300u) << std::string(e.what()).substr(0, 400);
      EXPECT_THAT(e.what(), HasSubstr("characters)"));
    }
  }
}

// Issue 33 (found by the Python front-end's fuzzer): a message quoted a whole argument, a model
// path of a million characters, an unexpected word, a --ctrl item: every message the command
// prints is bounded (BoundedMessage, kMaxMessage bytes) and quotes a value as an excerpt, with its
// control characters escaped.
TEST(Security, EveryMessageIsBounded) {
  const std::string tsui = MJSTEPPER_SOURCE_DIR "/models/tsui_rigid.xml";
  const std::string huge = std::string(100000, 'x') + "\x1b[2J";
  // (arguments, the longest message: an excerpt of the value, or CLI11's own words cut whole)
  const std::vector<std::pair<std::vector<std::string>, size_t>> cases = {
      {{"run", huge, "--duration", "1"}, 400},
      {{"run", tsui, "--duration", "1", "--ctrl", "shaft=" + huge}, 400},
      {{"run", tsui, "--duration", "1", "--ctrl", huge}, 400},
      {{"run", tsui, "--duration", "1", "--start", huge}, 400},
      {{"map", tsui, "--speeds", "10rpm", "--vary", huge}, 400},
      {{"run", tsui, "--duration", "1", huge}, mjstepper::kMaxMessage + 100}};
  for (const auto& [args, longest] : cases) {
    const Result r = Cli(args);
    EXPECT_NE(r.status, 0);
    EXPECT_LT(r.output.size(), longest) << r.output.substr(0, 600);
    EXPECT_EQ(r.output.find('\x1b'), std::string::npos) << r.output.substr(0, 600);
  }
  // The one bound behind them all: kept whole to kMaxMessage bytes, newlines kept.
  const std::string message = mjstepper::BoundedMessage("a\nb\x07" + std::string(5000, 'c'));
  EXPECT_EQ(message.substr(0, 8), "a\nb\\x07c");
  EXPECT_LE(message.size(), mjstepper::kMaxMessage + 40);
  EXPECT_THAT(message, HasSubstr("… (5004 characters)"));
}

// The README's option-range table and its list of every front-end's options (issue 32, item 1)
// are the ones generated from the tables the parser uses: an edited bound or option fails here
// until `mjstepper tables --write README.md` regenerates them.
TEST(Security, ReadmeCarriesTheOptionRangeTable) {
  std::ifstream in(MJSTEPPER_SOURCE_DIR "/README.md");
  std::stringstream text;
  text << in.rdbuf();
  const std::string readme = text.str();
  for (const auto& [name, table] :
       {std::pair{std::string("options"), mjstepper::tools::OptionRangeTableMarkdown()},
        std::pair{std::string("front-end"), mjstepper::tools::OptionListMarkdown()}}) {
    const std::string begin = "<!-- BEGIN " + name + " -->\n", end = "<!-- END " + name + " -->";
    const size_t b = readme.find(begin), e = readme.find(end);
    ASSERT_NE(b, std::string::npos) << name;
    ASSERT_NE(e, std::string::npos) << name;
    EXPECT_EQ(readme.substr(b + begin.size(), e - b - begin.size()), table) << name;
  }
}

}  // namespace

namespace mjstepper::tools {
namespace {

// Issue 32, item 5: a malformed command line exits 2 (CLI11's 105-109 before), a failed run 1,
// --version prints the version and the MuJoCo it was built against (README, "Exit status").
TEST(Conventions, UsageErrorsExitTwoFailedRunsOneAndVersionZero) {
  for (const std::vector<std::string>& args :
       std::vector<std::vector<std::string>>{{"run", kModel, "--duration", "0.01", "--bogus"},
                                             {"run"},
                                             {"run", kModel},
                                             {"run", "no/such/model.xml", "--duration", "1"},
                                             {"run", kModel, "--duration", "1e9"},
                                             {"frobnicate"}}) {
    const Result r = Cli(args);
    EXPECT_EQ(r.status, 2) << ::testing::PrintToString(args) << ": " << r.output;
  }
  const Result failed =
      Cli({"run", kModel, "--duration", "0.01", "--ctrl", "shaft=bogus(1)", "--quiet"});
  EXPECT_EQ(failed.status, 1) << failed.output;
  const Result version = Cli({"--version"});
  EXPECT_EQ(version.status, 0) << version.output;
  EXPECT_THAT(version.output, AllOf(HasSubstr("mjstepper 0."), HasSubstr("(MuJoCo 4.")));
}

// Issue 33 (low): `resonance-test --seed -1` wrapped to 2^64 − 1 and 99999999999999999999 was
// clamped, silently; `--out ''` wrote `_raw.csv` into the working folder. Both are usage errors
// now, named, and nothing is written.
TEST(Conventions, SeedsAndEmptyOutputPathsAreRefused) {
  const fs::path dir = FreshDir("seed");
  const std::string bed = MJSTEPPER_SOURCE_DIR "/models/bedslinger.xml";
  for (const char* seed : {"-1", "99999999999999999999", "1e3"}) {
    const Result r = Cli({"resonance-test", bed, "--axis", "y", "--seed", seed, "--out",
                          (dir / "r").string(), "--quiet"});
    EXPECT_EQ(r.status, 2) << seed << ": " << r.output;
    EXPECT_THAT(r.output, HasSubstr("--seed"));
  }
  for (const char* sub : {"resonance-test", "sweep", "size"}) {
    std::vector<std::string> args = {sub, bed, "--out", ""};
    if (std::string(sub) == "resonance-test") args.insert(args.end(), {"--axis", "x"});
    if (std::string(sub) == "sweep") args.insert(args.end(), {"--speeds", "10rpm"});
    const Result r = Cli(args);
    EXPECT_EQ(r.status, 2) << sub << ": " << r.output;
    EXPECT_THAT(r.output, HasSubstr("--out: an empty path")) << sub;
  }
  EXPECT_TRUE(Entries(dir).empty());
}

// Issue 33: an output prefix that is a device wrote beside it (`--out /dev/null` made
// /dev/null_raw.csv and /dev/null_psd.csv); a step list from a file whose read fails
// (/proc/self/mem) was "no step times".
TEST(Security, DevicePrefixesAndUnreadableStepFilesAreRefused) {
  const std::string bed = MJSTEPPER_SOURCE_DIR "/models/bedslinger.xml";
  std::error_code ignored;
  for (const char* suffix : {"_raw.csv", "_psd.csv"}) {
    fs::remove(std::string("/dev/null") + suffix, ignored);
  }
  Result r = Cli({"resonance-test", bed, "--axis", "y", "--out", "/dev/null", "--quiet"});
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_THAT(r.output, HasSubstr("'/dev/null' is a device or another special file"));
  EXPECT_FALSE(fs::exists("/dev/null_raw.csv"));
  EXPECT_FALSE(fs::exists("/dev/null_psd.csv"));
  r = Cli({"sweep", bed, "--speeds", "10rpm", "--out", "/dev/zero"});
  EXPECT_EQ(r.status, 2) << r.output;
  const std::string corexy = MJSTEPPER_SOURCE_DIR "/models/corexy.xml";
  r = Cli({"run", corexy, "--duration", "0.01", "--quiet", "--ctrl",
           "stepper_a=steps(/proc/self/mem)"});
  EXPECT_EQ(r.status, 1) << r.output;
  EXPECT_THAT(r.output, HasSubstr("/proc/self/mem: cannot be read (a read failed"));
}

// Issue 32, item 5: a too-coarse timestep is warned of once (it was printed three times: the
// plugin's load warning, cut at MuJoCo's 1000 characters, again whole, and the command's own).
TEST(Conventions, EachWarningOnce) {
  const std::string arm6 = MJSTEPPER_SOURCE_DIR "/models/arm6.xml";  // ships at 1 ms
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"run", arm6, "--duration", "0.002", "--allow-coarse", "--quiet"}, {"info", arm6}}) {
    const Result r = Cli(args);
    EXPECT_EQ(r.status, 0) << r.output;
    size_t count = 0;
    for (size_t at = r.output.find("too coarse"); at != std::string::npos;
         at = r.output.find("too coarse", at + 1)) {
      ++count;
    }
    EXPECT_EQ(count, 1u) << args[0] << ": " << r.output;
  }
}

}  // namespace
}  // namespace mjstepper::tools
