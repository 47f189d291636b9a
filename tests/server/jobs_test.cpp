// The training queue as the server uses it: real jobs of the motion-manifold
// tool (prepare, train, resume as child processes) on a small real H3.6M data
// root, records in SQLite, models published into a store.
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <set>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "server/jobs/job_spec_check.h"
#include "server/jobs/model_publication.h"
#include "server/jobs/sqlite_job_store.h"
#include "server/jobs/training_jobs.h"
#include "tests/common/command_run.h"
#include "tests/common/test_environment.h"

namespace mm::service {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

using nlohmann::json;
using test::read_text;

// Runs the tool as a user would; returns its exit status.
int run_tool(const std::string& arguments, const fs::path& output) {
  const std::string command = std::string(MM_TOOL_PATH) + " " + arguments + " > " + output.string() + " 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Processes whose command line mentions `text` (a job's folder): the job's
// children, wherever they were started from.
std::vector<pid_t> processes_mentioning(const std::string& text) {
  std::vector<pid_t> found;
  for (const auto& entry : fs::directory_iterator("/proc")) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::string cmdline = read_text(entry.path() / "cmdline");
    for (char& c : cmdline) c = c == '\0' ? ' ' : c;
    if (cmdline.find(text) != std::string::npos && std::stoi(name) != getpid()) found.push_back(std::stoi(name));
  }
  return found;
}

// A process's nice value and scheduling policy (/proc/<pid>/stat fields 19
// and 41; policy 5 is SCHED_IDLE, 0 SCHED_OTHER).
struct Scheduling {
  std::string nice, policy;
};
Scheduling scheduling_of(pid_t pid) {
  const std::string stat = read_text("/proc/" + std::to_string(pid) + "/stat");
  std::istringstream fields(stat.substr(stat.rfind(')') + 2));  // from field 3, the state
  std::vector<std::string> field(3);
  for (std::string value; fields >> value;) field.push_back(value);
  if (field.size() <= 41) return {};
  return {field[19], field[41]};
}

bool eventually(const std::function<bool()>& condition, std::chrono::seconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(50ms);
  }
  return condition();
}

// Asserts that `call` throws ApiError with this code and field, and returns
// its message.
std::string refusal(const std::function<void()>& call, ErrorCode code, const std::string& field) {
  try {
    call();
  } catch (const ApiError& e) {
    EXPECT_EQ(error_code_name(e.code()), std::string(error_code_name(code))) << e.what();
    EXPECT_EQ(e.field(), field) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no ApiError (expected " << error_code_name(code) << " on \"" << field << "\")";
  return "";
}

// The model's weight files (everything but the manifest, whose provenance
// names the commands, and the card).
std::map<std::string, std::string> weight_files(const fs::path& model) {
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::directory_iterator(model)) {
    const std::string name = entry.path().filename().string();
    if (name != "manifest.json" && name != "MODEL_CARD.md") files[name] = read_text(entry.path());
  }
  return files;
}

class TrainingJobsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    MM_REQUIRE_H36M();
    data_root_ = scratch_.path() / "data";
    // A small H3.6M text tree: one training file of S1 and one test file of S5.
    for (const auto& [subject, file] : {std::pair{"S1", "posing_2.txt"}, std::pair{"S5", "greeting_1.txt"}}) {
      fs::create_directories(data_root_ / "h36m" / subject);
      fs::create_symlink(mm::test::h36m_dataset_dir() / subject / file, data_root_ / "h36m" / subject / file);
    }
    config_.state_dir = (scratch_.path() / "state").string();
    config_.data_root = data_root_.string();
    config_.model_store = (scratch_.path() / "models").string();
    config_.tool_path = MM_TOOL_PATH;
    config_.training_threads = 1;
    config_.checkpoint_every = 20;
  }

  // The tiny run every job here trains: variant D, hidden 16, batch 4.
  JobSpec tiny_spec(int64_t iterations = 40) const {
    JobSpec spec;
    spec.dataset = "h36m";
    spec.variant = "D";
    spec.iterations = iterations;
    spec.seed = 3;
    spec.hidden = 16;
    spec.batch = 4;
    return spec;
  }

  // The record of job `id` in the state folder's SQLite store, its spec
  // column as a server that did not resolve configurations wrote it (the spec
  // alone, of `variant`), read back.
  std::optional<JobInfo> record_stored_without_configuration(const std::string& id, const std::string& variant) {
    fs::create_directories(config_.state_dir);
    const std::string database = (fs::path(config_.state_dir) / "jobs.sqlite").string();
    JobInfo job;
    job.id = id;
    job.spec = tiny_spec(20);
    job.created_at = 1;
    SqliteJobStore records(database);
    if (!records.insert_if_room(job, 10)) return std::nullopt;
    SqliteDatabase(database).execute(
        R"(UPDATE jobs SET spec = '{"batch":4,"config":"","dataset":"h36m","hidden":16,"iterations":20,)"
        R"("model_name":"","seed":"3","variant":")" + variant + R"("}' WHERE id = ')" + id + "'");
    return records.find(id);
  }

  std::unique_ptr<TrainingJobs> make_jobs(const JobsConfig& config) {
    auto jobs = std::make_unique<TrainingJobs>(
        config,
        [this](const std::string& name) {
          std::lock_guard<std::mutex> lock(published_mutex_);
          published_.push_back(name);
        },
        hooks_);
    jobs->start();
    return jobs;
  }
  std::unique_ptr<TrainingJobs> make_jobs() { return make_jobs(config_); }

  // Polls until the job is finished; fails the test after `timeout`.
  // Generous: the jobs' children run at SCHED_IDLE and wait for an idle CPU
  // on a busy machine.
  JobInfo wait_finished(const TrainingJobs& jobs, const std::string& id, std::chrono::seconds timeout = 300s) {
    JobInfo job;
    const bool finished = eventually(
        [&] {
          job = jobs.get(id);
          return is_terminal(job.state);
        },
        timeout);
    EXPECT_TRUE(finished) << "job " << id << " still " << job_state_name(job.state) << " after " << timeout.count()
                          << " s";
    return job;
  }

  // Writes <data root>/prepared/h36m.mmd with the tool.
  std::string prepare_dataset_file() {
    fs::create_directories(data_root_ / "prepared");
    const fs::path file = data_root_ / "prepared" / "h36m.mmd";
    EXPECT_EQ(run_tool("prepare --data " + (data_root_ / "h36m").string() + " --out " + file.string() +
                           " --train S1 --test S5",
                       scratch_.path() / "prepare.out"),
              0)
        << read_text(scratch_.path() / "prepare.out");
    return "prepared/h36m.mmd";
  }

  // A job that passes submission and fails in the tool: its dataset is a
  // prepared dataset's header, then not the rest, which the tool refuses
  // when it loads it ("truncated file").
  JobSpec failing_spec() const {
    std::ofstream(data_root_ / "truncated.mmd", std::ios::binary) << std::string("MMPREP\r\n\x01\0\0\0garbage", 19);
    JobSpec spec = tiny_spec();
    spec.dataset = "truncated.mmd";
    return spec;
  }

  fs::path job_dir(const JobsConfig& config, const std::string& id) const {
    return fs::path(config.state_dir) / "jobs" / id;
  }

  // Trains `spec` without interruption in a state folder of its own and
  // returns the published model's weight files.
  std::map<std::string, std::string> uninterrupted_weights(const JobSpec& spec) {
    JobsConfig config = config_;
    config.state_dir = (scratch_.path() / "reference-state").string();
    config.model_store = (scratch_.path() / "reference-models").string();
    auto jobs = make_jobs(config);
    const JobInfo job = wait_finished(*jobs, jobs->submit(spec).id);
    EXPECT_EQ(job_state_name(job.state), std::string("succeeded")) << job.error;
    EXPECT_EQ(job.resumes, 0);
    return weight_files(fs::path(config.model_store) / job.published_model);
  }

  mm::test::ScratchDir scratch_;
  fs::path data_root_;
  JobsConfig config_;
  JobsTestHooks hooks_;  // given to every TrainingJobs make_jobs() makes
  std::mutex published_mutex_;
  std::vector<std::string> published_;
};

TEST_F(TrainingJobsTest, SubmissionRefusesDatasetsOutsideTheDataRootOrNotDatasets) {
  // A valid text tree outside the root, reached by .., by a symbolic link
  // inside the root and by its absolute path.
  const fs::path outside = scratch_.path() / "outside";
  fs::create_directories(outside / "S1");
  fs::create_symlink(mm::test::h36m_dataset_dir() / "S1" / "posing_2.txt", outside / "S1" / "posing_2.txt");
  fs::create_symlink(outside, data_root_ / "escape");
  fs::create_directories(data_root_ / "empty");
  fs::create_directories(data_root_ / "only-s5" / "S5");
  fs::create_symlink(mm::test::h36m_dataset_dir() / "S5" / "greeting_1.txt", data_root_ / "only-s5" / "S5" / "greeting_1.txt");
  std::ofstream(data_root_ / "notes.txt") << "not a dataset\n";
  std::ofstream(data_root_ / "fake.mmd") << "MMPREQ\r\n\x01\0\0\0 not the magic";
  auto jobs = make_jobs();

  for (const std::string& dataset : std::vector<std::string>{"../outside", "h36m/../../outside", "escape", "escape/S1",
                                    outside.string(), "../data/../outside"}) {
    JobSpec spec = tiny_spec();
    spec.dataset = dataset;
    const std::string message = refusal([&] { jobs->submit(spec); }, ErrorCode::kInvalidArgument, "dataset");
    EXPECT_NE(message.find(dataset), std::string::npos) << message;
    EXPECT_NE(message.find("outside the data root"), std::string::npos) << message;
  }
  for (const std::string dataset : std::vector<std::string>{"notes.txt", "fake.mmd", "empty", "only-s5", "missing", "missing.mmd", ""}) {
    JobSpec spec = tiny_spec();
    spec.dataset = dataset;
    const std::string message = refusal([&] { jobs->submit(spec); }, ErrorCode::kInvalidArgument, "dataset");
    EXPECT_NE(message.find("expected"), std::string::npos) << message;
    EXPECT_EQ(message.find("outside"), std::string::npos) << dataset << ": " << message;
  }
  // A rig's folder whose files name one sequence twice (a file's name
  // without its extension names it), at submission, before any is read.
  fs::create_directories(data_root_ / "twins");
  for (const char* name : {"a.bvh", "a.glb", "b.fbx"}) std::ofstream(data_root_ / "twins" / name) << "not read\n";
  JobSpec twins = tiny_spec();
  twins.dataset = "twins";
  const std::string message = refusal([&] { jobs->submit(twins); }, ErrorCode::kInvalidArgument, "dataset");
  EXPECT_NE(message.find("a.bvh and a.glb are two files of the name \"a\""), std::string::npos) << message;
  EXPECT_TRUE(jobs->list().empty());
  EXPECT_EQ(jobs->counts()[JobState::kQueued], 0);
}

TEST_F(TrainingJobsTest, SubmissionRefusesBadFieldsNamingThem) {
  fs::create_directories(fs::path(config_.model_store) / "taken");
  auto jobs = make_jobs();
  struct Case {
    std::function<void(JobSpec&)> change;
    std::string field;
    ErrorCode code = ErrorCode::kInvalidArgument;
  };
  const std::vector<Case> cases{
      {[](JobSpec& s) { s.variant = "DKX"; }, "variant"},
      {[](JobSpec& s) { s.variant = ""; }, "variant"},
      {[](JobSpec& s) { s.iterations = -1; }, "iterations"},
      {[](JobSpec& s) { s.iterations = 10'000'001; }, "iterations"},
      // Within the hard limit, beyond the server's (--max-job-iterations).
      {[](JobSpec& s) { s.iterations = 1'000'001; }, "iterations", ErrorCode::kResourceExhausted},
      {[](JobSpec& s) { s.hidden = 7; }, "hidden"},
      {[](JobSpec& s) { s.hidden = 4097; }, "hidden"},
      {[](JobSpec& s) { s.batch = -1; }, "batch"},
      {[](JobSpec& s) { s.batch = 1025; }, "batch"},
      {[](JobSpec& s) { s.config_json = "{\"variant\": \"D\""; }, "config"},
      {[](JobSpec& s) { s.config_json = "[1, 2]"; }, "config"},
      {[](JobSpec& s) { s.config_json = "{\"variant\": \"Q\"}"; }, "config"},
      // Read as the tool reads it: unknown fields, wrong types, its ranges.
      {[](JobSpec& s) { s.config_json = R"({"variant": "D", "no_such_field": 1})"; }, "config"},
      {[](JobSpec& s) { s.config_json = R"({"model": {"hidden": "wide"}})"; }, "config"},
      {[](JobSpec& s) { s.config_json = R"({"batch": 1})"; }, "config"},
      // The limits of the spec's own fields hold for the configuration's,
      // where the spec does not set the field.
      {[](JobSpec& s) { s.iterations = 0, s.config_json = R"({"iterations": 1000000000000})"; }, "config"},
      {[](JobSpec& s) { s.hidden = 0, s.config_json = R"({"model": {"hidden": 65536}})"; }, "config"},
      {[](JobSpec& s) { s.batch = 0, s.config_json = R"({"batch": 100000})"; }, "config"},
      {[](JobSpec& s) { s.config_json = std::string(100, '[') + std::string(100, ']'); }, "config"},
      {[](JobSpec& s) { s.batch = 1; }, "batch"},  // the MMD estimate needs two samples
      {[](JobSpec& s) { s.model_name = "a/b"; }, "model_name"},
      {[](JobSpec& s) { s.model_name = ".."; }, "model_name"},
      {[](JobSpec& s) { s.model_name = std::string(65, 'm'); }, "model_name"},
      {[](JobSpec& s) { s.model_name = "job-0123456789ab"; }, "model_name"},  // an unnamed job's
      {[](JobSpec& s) { s.model_name = "taken"; }, "model_name", ErrorCode::kFailedPrecondition},
  };
  for (const auto& c : cases) {
    JobSpec spec = tiny_spec();
    c.change(spec);
    refusal([&] { jobs->submit(spec); }, c.code, c.field);
  }
  EXPECT_TRUE(jobs->list().empty());
  refusal([&] { jobs->get("000000000000"); }, ErrorCode::kNotFound, "id");
  refusal([&] { jobs->cancel("000000000000"); }, ErrorCode::kNotFound, "id");
  // The limits themselves are accepted (then cancelled before they run long).
  JobSpec edge = tiny_spec();
  edge.iterations = config_.max_iterations;
  edge.hidden = 8;
  edge.batch = 1024;
  edge.model_name = std::string(64, 'm');
  const JobInfo job = jobs->submit(edge);
  EXPECT_EQ(job.id.size(), 12u);
  EXPECT_EQ(job.id.find_first_not_of("0123456789abcdef"), std::string::npos) << job.id;
  jobs->cancel(job.id);
}

// A user's own tree may hold no S5: it trains without a test set. A folder
// named like a subject with a number past an int's range is no subject.
TEST_F(TrainingJobsTest, TextTreeWithoutTheTestSubjectTrainsWithoutATestSet) {
  const fs::path tree = data_root_ / "own";
  fs::create_directories(tree / "S1");
  fs::create_symlink(mm::test::h36m_dataset_dir() / "S1" / "posing_2.txt", tree / "S1" / "posing_2.txt");
  fs::create_directories(tree / "S99999999999");
  fs::create_symlink(mm::test::h36m_dataset_dir() / "S1" / "posing_1.txt", tree / "S99999999999" / "walking_1.txt");
  auto jobs = make_jobs();
  JobSpec spec = tiny_spec(4);
  spec.dataset = "own";
  const JobInfo job = wait_finished(*jobs, jobs->submit(spec).id);
  ASSERT_EQ(job_state_name(job.state), std::string("succeeded")) << job.error;
  const std::string log = read_text(job_dir(config_, job.id) / "train.log");
  EXPECT_NE(log.find("test:  0 sequences"), std::string::npos) << log;
}

TEST_F(TrainingJobsTest, TextTreeJobSucceedsAndPublishesALoadableModel) {
  auto jobs = make_jobs();
  const JobInfo submitted = jobs->submit(tiny_spec());
  EXPECT_EQ(job_state_name(submitted.state), std::string("queued"));
  EXPECT_GT(submitted.created_at, 0);

  std::vector<JobInfo> events;
  jobs->watch(submitted.id, [&](const JobInfo& job) {
    events.push_back(job);
    return true;
  }, nullptr);
  ASSERT_GE(events.size(), 3u);
  const JobInfo job = events.back();
  ASSERT_EQ(job_state_name(job.state), std::string("succeeded")) << job.error;
  bool saw_running = false;
  for (size_t i = 1; i < events.size(); ++i) {
    EXPECT_GE(events[i].progress.iteration, events[i - 1].progress.iteration);
    EXPECT_FALSE(is_terminal(events[i - 1].state));
    saw_running = saw_running || events[i].state == JobState::kRunning;
  }
  EXPECT_TRUE(saw_running);
  EXPECT_EQ(job.progress.iteration, 40);
  EXPECT_EQ(job.progress.total, 40);
  EXPECT_GT(job.progress.iterations_per_second, 0);
  EXPECT_GE(job.started_at, job.created_at);
  EXPECT_GE(job.finished_at, job.started_at);
  EXPECT_EQ(job.resumes, 0);

  // Every loss term the run logs is in the progress.
  const fs::path dir = job_dir(config_, job.id);
  std::istringstream log(read_text(dir / "run" / "train_log.csv"));
  std::string header;
  std::getline(log, header);
  std::set<std::string> terms;
  std::istringstream columns(header);
  for (std::string column; std::getline(columns, column, ',');) {
    if (column != "iteration" && column != "learning_rate") terms.insert(column);
  }
  std::set<std::string> reported;
  for (const auto& [name, value] : job.progress.losses) reported.insert(name);
  EXPECT_EQ(reported, terms) << header;
  EXPECT_TRUE(fs::is_regular_file(dir / "dataset.mmd"));  // prepared from the text tree
  EXPECT_TRUE(fs::is_regular_file(dir / "train.log"));

  // Published as job-<id>, whole, with its card, and loadable by the tool.
  EXPECT_EQ(job.published_model, "job-" + job.id);
  // on_published follows the record on the worker thread.
  EXPECT_TRUE(eventually(
      [&] {
        std::lock_guard<std::mutex> lock(published_mutex_);
        return published_ == std::vector<std::string>{job.published_model};
      },
      10s));
  const fs::path model = fs::path(config_.model_store) / job.published_model;
  for (const char* file : {"manifest.json", "encoder.pt", "rotation_decoder.pt", "velocity_decoder.pt"}) {
    EXPECT_TRUE(fs::is_regular_file(model / file)) << file;
  }
  const std::string card = read_text(model / "MODEL_CARD.md");
  EXPECT_NE(card.find(job.id), std::string::npos) << card;
  EXPECT_NE(card.find("| L_ang |"), std::string::npos) << card;
  EXPECT_NE(card.find("40 of 40"), std::string::npos) << card;
  for (const auto& entry : fs::directory_iterator(config_.model_store)) {
    EXPECT_NE(entry.path().filename().string()[0], '.') << "left behind: " << entry.path();
  }
  const fs::path samples = scratch_.path() / "samples";
  EXPECT_EQ(run_tool("sample --model " + model.string() + " --count 2 --seed 1 --out-dir " + samples.string(),
                     scratch_.path() / "sample.out"),
            0)
      << read_text(scratch_.path() / "sample.out");
  EXPECT_TRUE(fs::is_regular_file(samples / "sample_001.txt"));

  // A finished job's watch reports it once and returns.
  int calls = 0;
  jobs->watch(job.id, [&](const JobInfo&) { return ++calls < 100; }, nullptr);
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(jobs->counts()[JobState::kSucceeded], 1);
}

TEST_F(TrainingJobsTest, PreparedFileJobPublishesUnderItsModelName) {
  JobSpec spec = tiny_spec(30);
  spec.dataset = prepare_dataset_file();
  spec.model_name = "tiny-d";
  auto jobs = make_jobs();
  const JobInfo job = wait_finished(*jobs, jobs->submit(spec).id);
  ASSERT_EQ(job_state_name(job.state), std::string("succeeded")) << job.error;
  EXPECT_EQ(job.published_model, "tiny-d");
  EXPECT_EQ(job.progress.iteration, 30);
  EXPECT_TRUE(fs::is_regular_file(fs::path(config_.model_store) / "tiny-d" / "manifest.json"));
  EXPECT_TRUE(fs::is_regular_file(fs::path(config_.model_store) / "tiny-d" / "encoder.pt"));
  EXPECT_FALSE(fs::exists(job_dir(config_, job.id) / "dataset.mmd"));  // used in place, not prepared again
  // The name is now taken.
  refusal([&] { jobs->submit(spec); }, ErrorCode::kFailedPrecondition, "model_name");
}

// At submission the spec and its configuration resolve into one whole
// training configuration, by the tool's own rule: the record holds it, and
// the child trains it from a file, its command line naming no spec field.
TEST_F(TrainingJobsTest, ASubmittedJobHoldsItsWholeConfigurationAndItsChildIsGivenNoSpecField) {
  JobSpec spec = tiny_spec(30);  // iterations 30, seed 3, hidden 16, batch 4
  spec.variant = "";
  spec.config_json = R"({"variant": "D", "learning_rate": 0.002, "batch": 12, "model": {"hidden": 64}})";
  auto jobs = make_jobs();
  const JobInfo submitted = jobs->submit(spec);
  for (const JobInfo& record : {submitted, jobs->get(submitted.id)}) {
    const json c = json::parse(record.resolved_config_json);
    // The spec's fields where it gives them.
    EXPECT_EQ(c["iterations"], 30);
    EXPECT_EQ(c["seed"], 3);
    EXPECT_EQ(c["model"]["hidden"], 16);
    EXPECT_EQ(c["batch"], 4);
    // The configuration's, and for what it does not say, variant D's defaults.
    EXPECT_EQ(c["learning_rate"], 0.002);
    EXPECT_EQ(c["variant"], "D");
    EXPECT_EQ(c["weights"]["position"], 0.0);
    EXPECT_EQ(c["weights"]["manifold"], 0.0);
    EXPECT_EQ(c["weights"]["wasserstein"], 0.1);
    EXPECT_EQ(c["model"]["latent"], 64);
    EXPECT_EQ(c["model"]["frames"], 150);
    EXPECT_EQ(c["lr_decay"], 0.999);
    EXPECT_EQ(c["decay_every"], 20);
    EXPECT_EQ(c["losses"]["preset"], "frame-norm");
    // The dataset's pose dimensions, and the server's own paths, are the run's.
    EXPECT_FALSE(c["model"].contains("pose_dims")) << c.dump();
    EXPECT_EQ(c["dataset"], "");
    EXPECT_EQ(c["output_dir"], "");
  }

  const JobInfo job = wait_finished(*jobs, submitted.id);
  ASSERT_EQ(job_state_name(job.state), std::string("succeeded")) << job.error;
  EXPECT_EQ(job.progress.iteration, 30);
  const fs::path model = fs::path(config_.model_store) / job.published_model;
  const std::string command = json::parse(read_text(model / "manifest.json"))["provenance"]["command"];
  EXPECT_NE(command.find(" train --config " + (job_dir(config_, job.id) / "config.json").string()), std::string::npos)
      << command;
  for (const char* flag : {"--iterations", "--seed", "--hidden", "--batch", "--variant"}) {
    EXPECT_EQ(command.find(flag), std::string::npos) << flag << " in " << command;
  }
  // What the tool trained: the record's configuration, with the dataset's
  // pose dimensions and the server's checkpoint interval.
  const json trained = json::parse(read_text(job_dir(config_, job.id) / "run" / "config.json"));
  json expected = json::parse(job.resolved_config_json);
  expected["model"]["pose_dims"] = 51;  // H3.6M's kept columns
  expected["checkpoint_every"] = config_.checkpoint_every;
  expected["dataset"] = trained["dataset"];
  expected["output_dir"] = trained["output_dir"];
  EXPECT_EQ(trained, expected);
  // The model card states the values trained.
  const std::string card = read_text(model / "MODEL_CARD.md");
  for (const char* row : {"| variant | D |", "| iterations requested | 30 |", "| seed | 3 |", "| hidden | 16 |",
                          "| batch | 4 |"}) {
    EXPECT_NE(card.find(row), std::string::npos) << row << " not in\n" << card;
  }
}

// A record stored by a server that did not resolve configurations (its spec
// column holds the spec alone) loads with its spec resolved by the same rule,
// and runs.
TEST_F(TrainingJobsTest, ARecordStoredWithoutAResolvedConfigurationLoadsResolvedAndRuns) {
  const std::string id = "0123456789ab";
  {
    const auto stored = record_stored_without_configuration(id, "D");
    ASSERT_TRUE(stored);
    EXPECT_EQ(stored->spec.hidden, 16);
    // Typed, and the wire's text of the same.
    ASSERT_TRUE(stored->resolved_config);
    EXPECT_EQ(stored->resolved_config->config.model.hidden, 16);
    EXPECT_EQ(stored->resolved_config->config.iterations, 20);
    EXPECT_EQ(stored->resolved_config->config.seed, 3u);
    EXPECT_TRUE(stored->resolved_config->pose_dims_from_dataset);
    const json c = json::parse(stored->resolved_config_json);
    EXPECT_EQ(c["model"]["hidden"], 16);
    EXPECT_EQ(c["iterations"], 20);
    EXPECT_EQ(c["variant"], "D");
  }
  auto jobs = make_jobs();
  const JobInfo job = wait_finished(*jobs, id);
  ASSERT_EQ(job_state_name(job.state), std::string("succeeded")) << job.error;
  EXPECT_EQ(job.progress.iteration, 20);
  EXPECT_EQ(json::parse(job.resolved_config_json)["batch"], 4);
  const json trained = json::parse(read_text(job_dir(config_, id) / "run" / "config.json"));
  EXPECT_EQ(trained["model"]["hidden"], 16);
  EXPECT_EQ(trained["seed"], 3);
}

// Such a record whose spec no longer resolves (here an unknown variant)
// loads without a configuration, and its job fails at once saying so,
// rather than training something else.
TEST_F(TrainingJobsTest, ARecordStoredWithoutAConfigurationThatNoLongerResolvesFailsSayingSo) {
  const std::string id = "0123456789cd";
  {
    const auto stored = record_stored_without_configuration(id, "DQ");
    ASSERT_TRUE(stored);
    EXPECT_FALSE(stored->resolved_config);
    EXPECT_EQ(stored->resolved_config_json, "");
  }
  auto jobs = make_jobs();
  const JobInfo job = wait_finished(*jobs, id);
  ASSERT_EQ(job_state_name(job.state), std::string("failed"));
  EXPECT_NE(job.error.find("holds no training configuration"), std::string::npos) << job.error;
  EXPECT_FALSE(fs::exists(job_dir(config_, id) / "run")) << "nothing was trained";
}

TEST_F(TrainingJobsTest, RecordsSurviveANewTrainingJobsOnTheSameStateDir) {
  std::vector<std::string> before;
  std::string finished_id;
  {
    auto jobs = make_jobs();
    const std::string failed_id = jobs->submit(failing_spec()).id;
    finished_id = jobs->submit(tiny_spec(20)).id;
    wait_finished(*jobs, failed_id);
    wait_finished(*jobs, finished_id);
    for (const JobInfo& job : jobs->list()) before.push_back(job_to_json_text(job));
  }
  auto jobs = make_jobs();
  std::vector<std::string> after;
  for (const JobInfo& job : jobs->list()) after.push_back(job_to_json_text(job));
  ASSERT_EQ(after.size(), 2u);
  EXPECT_EQ(after, before);
  EXPECT_EQ(jobs->list().front().id, finished_id);  // newest first
  const JobInfo finished = jobs->get(finished_id);
  EXPECT_EQ(job_state_name(finished.state), std::string("succeeded"));
  EXPECT_EQ(finished.progress.iteration, 20);
  EXPECT_FALSE(finished.progress.losses.empty());
  EXPECT_EQ(finished.published_model, "job-" + finished_id);
  auto counts = jobs->counts();
  EXPECT_EQ(counts[JobState::kSucceeded], 1);
  EXPECT_EQ(counts[JobState::kFailed], 1);
  EXPECT_EQ(counts[JobState::kQueued], 0);
}

TEST_F(TrainingJobsTest, FailedJobRecordsTheToolsError) {
  auto jobs = make_jobs();
  const JobInfo job = wait_finished(*jobs, jobs->submit(failing_spec()).id);
  ASSERT_EQ(job_state_name(job.state), std::string("failed"));
  EXPECT_NE(job.error.find("exited with status 2"), std::string::npos) << job.error;
  EXPECT_NE(job.error.find("truncated file"), std::string::npos) << job.error;
  EXPECT_TRUE(job.published_model.empty());
  EXPECT_GT(job.finished_at, 0);
  EXPECT_NE(read_text(job_dir(config_, job.id) / "train.log").find("truncated file"), std::string::npos);
  std::lock_guard<std::mutex> lock(published_mutex_);
  EXPECT_TRUE(published_.empty());
}

// Whoever reads "succeeded" can use the model: it is in place, whole, while
// the record still says running (a client that watched a job to its end
// once found no model there).
TEST_F(TrainingJobsTest, TheModelIsInPlaceBeforeTheRecordSaysSucceeded) {
  bool checked = false;
  hooks_.before_publication_commit = [&](const std::string& id) {
    SqliteJobStore other((fs::path(config_.state_dir) / "jobs.sqlite").string());
    EXPECT_EQ(job_state_name(other.find(id)->state), std::string("running"));
    EXPECT_TRUE(fs::is_regular_file(fs::path(config_.model_store) / "in-place" / "manifest.json"));
    EXPECT_TRUE(fs::is_regular_file(fs::path(config_.model_store) / "in-place" / "MODEL_CARD.md"));
    checked = true;
  };
  JobSpec spec = tiny_spec(20);
  spec.model_name = "in-place";
  auto jobs = make_jobs();
  const JobInfo job = wait_finished(*jobs, jobs->submit(spec).id);
  ASSERT_TRUE(checked);
  EXPECT_EQ(job_state_name(job.state), std::string("succeeded")) << job.error;
  EXPECT_EQ(job.published_model, "in-place");
}

// Another replica's cancel reaching the shared record after this replica's
// last lease renewal, while the finished model is being published: the
// cancel wins, and the model is withdrawn, none stays (written here through
// a second connection to the same database, as a replica would).
TEST_F(TrainingJobsTest, ACancelWrittenBeforeThePublicationIsCommittedWinsAndNoModelAppears) {
  bool cancel_written = false;
  hooks_.before_publication_commit = [&](const std::string& id) {
    SqliteJobStore other((fs::path(config_.state_dir) / "jobs.sqlite").string());
    JobInfo record = *other.find(id);
    record.state = JobState::kCancelled;
    record.finished_at = 1;
    cancel_written = other.update_state_if(record, JobState::kRunning);
  };
  JobSpec spec = tiny_spec(20);
  spec.model_name = "cancelled-late";
  auto jobs = make_jobs();
  const JobInfo job = wait_finished(*jobs, jobs->submit(spec).id);
  // The record says cancelled as soon as the other replica writes it; the
  // worker withdraws the model after. Shutting down joins the worker, so the
  // checks below see what it left, not a withdrawal half done.
  jobs.reset();
  ASSERT_TRUE(cancel_written);
  EXPECT_EQ(job_state_name(job.state), std::string("cancelled"));
  EXPECT_TRUE(job.published_model.empty());
  EXPECT_FALSE(fs::exists(fs::path(config_.model_store) / "cancelled-late"));
  EXPECT_FALSE(fs::exists(fs::path(config_.model_store) / (".job-" + job.id + ".tmp")));
  std::lock_guard<std::mutex> lock(published_mutex_);
  EXPECT_TRUE(published_.empty());
}

// Another replica finishing the job between this replica's read of the
// record and its cancel: the cancel is refused with the state the record
// now has, and that state stays (the cancel never overwrites it).
TEST_F(TrainingJobsTest, ACancelLosingToAnotherReplicasFinishIsRefusedAndLeavesTheRecord) {
  bool finish_written = false;
  hooks_.before_cancel_commit = [&](const std::string& id) {
    SqliteJobStore other((fs::path(config_.state_dir) / "jobs.sqlite").string());
    JobInfo record = *other.find(id);
    const JobState seen = record.state;
    record.state = JobState::kSucceeded;
    record.finished_at = 1;
    finish_written = other.update_state_if(record, seen);
  };
  auto jobs = make_jobs();
  const JobInfo job = jobs->submit(tiny_spec(100000));
  try {
    jobs->cancel(job.id);
    ADD_FAILURE() << "a cancel after another replica finished the job was accepted";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.code(), ErrorCode::kFailedPrecondition);
    EXPECT_EQ(e.field(), "id");
    EXPECT_NE(std::string(e.what()).find("already succeeded"), std::string::npos) << e.what();
  }
  ASSERT_TRUE(finish_written);
  EXPECT_EQ(job_state_name(jobs->get(job.id).state), std::string("succeeded"));
}

// A crash between committing the record and renaming the staged model
// leaves a succeeded record and a staged folder: the next start publishes
// it. Staged folders of cancelled or unknown jobs are removed.
TEST_F(TrainingJobsTest, AModelStagedBeforeACrashIsPublishedAtStartAndStaleOnesAreRemoved) {
  fs::create_directories(config_.state_dir);
  const fs::path store(config_.model_store);
  auto record = [&](const std::string& id, JobState state, const std::string& model) {
    JobInfo job;
    job.id = id;
    job.spec = tiny_spec();
    set_resolved_config(job, resolve_job_config(job.spec));
    job.state = state;
    job.published_model = model;
    job.created_at = job.finished_at = 1;
    return job;
  };
  auto stage = [&](const std::string& id) {
    const fs::path folder = store / (".job-" + id + ".tmp");
    fs::create_directories(folder);
    std::ofstream(folder / "manifest.json") << "{}";
    std::ofstream(folder / "MODEL_CARD.md") << job_model_card(record(id, JobState::kRunning, ""), 1);
  };
  {
    SqliteJobStore records((fs::path(config_.state_dir) / "jobs.sqlite").string());
    ASSERT_TRUE(records.insert_if_room(record("succeeded1", JobState::kSucceeded, "crashed-before-rename"), 10));
    ASSERT_TRUE(records.insert_if_room(record("cancelled1", JobState::kCancelled, ""), 10));
  }
  stage("succeeded1");
  stage("cancelled1");
  stage("unknown1");
  auto jobs = make_jobs();
  EXPECT_TRUE(fs::is_regular_file(store / "crashed-before-rename" / "manifest.json"));
  EXPECT_NE(read_text(store / "crashed-before-rename" / "MODEL_CARD.md").find("succeeded1"), std::string::npos);
  for (const char* id : {"succeeded1", "cancelled1", "unknown1"}) {
    EXPECT_FALSE(fs::exists(store / (std::string(".job-") + id + ".tmp"))) << id;
  }
}

TEST_F(TrainingJobsTest, CancelStopsQueuedAndRunningJobsAndRefusesFinishedOnes) {
  // The child's OMP_NUM_THREADS=1 below must be the service's doing, not
  // inherited from a test run that bounds every process (.ci/run does).
  const char* const inherited = std::getenv("OMP_NUM_THREADS");
  const std::string restore = inherited != nullptr ? inherited : "";
  setenv("OMP_NUM_THREADS", "2", 1);
  struct Restore {
    std::string value;
    ~Restore() { value.empty() ? unsetenv("OMP_NUM_THREADS") : setenv("OMP_NUM_THREADS", value.c_str(), 1); }
  } restore_afterwards{restore};
  config_.max_queued = 1;
  auto jobs = make_jobs();
  const std::string running = jobs->submit(tiny_spec(1'000'000)).id;
  ASSERT_TRUE(eventually([&] { return jobs->get(running).progress.iteration >= 10; }, 180s))
      << job_state_name(jobs->get(running).state) << " " << jobs->get(running).error;
  const std::string queued = jobs->submit(tiny_spec()).id;
  // The queue holds its one queued job: the next submission is refused.
  refusal([&] { jobs->submit(tiny_spec()); }, ErrorCode::kResourceExhausted, "");

  // A watcher whose stop flag is set returns within a poll interval.
  std::atomic<bool> stop{true};
  const auto watch_started = std::chrono::steady_clock::now();
  jobs->watch(running, [](const JobInfo&) { return true; }, &stop);
  EXPECT_LT(std::chrono::steady_clock::now() - watch_started, 2s);

  const JobInfo cancelled_queued = jobs->cancel(queued);
  EXPECT_EQ(job_state_name(cancelled_queued.state), std::string("cancelled"));
  EXPECT_EQ(job_state_name(jobs->get(queued).state), std::string("cancelled"));

  const fs::path dir = job_dir(config_, running);
  const auto children = processes_mentioning(dir.string());
  ASSERT_EQ(children.size(), 1u) << "the running job should have one child";
  // The child runs at the lowest priority (SCHED_IDLE, nice 19) with its
  // threads bounded.
  const Scheduling child = scheduling_of(children[0]);
  EXPECT_EQ(child.nice, "19");
  EXPECT_EQ(child.policy, "5") << "scheduling policy (5 = SCHED_IDLE)";
  std::string environment = read_text("/proc/" + std::to_string(children[0]) + "/environ");
  for (char& c : environment) c = c == '\0' ? '\n' : c;
  EXPECT_NE(("\n" + environment).find("\nOMP_NUM_THREADS=1\n"), std::string::npos);

  EXPECT_EQ(job_state_name(jobs->cancel(running).state), std::string("cancelled"));
  EXPECT_TRUE(eventually([&] { return processes_mentioning(dir.string()).empty(); }, 180s)) << "the child lives on";
  const JobInfo cancelled_running = jobs->get(running);
  EXPECT_EQ(job_state_name(cancelled_running.state), std::string("cancelled"));
  EXPECT_TRUE(cancelled_running.published_model.empty());
  EXPECT_LT(cancelled_running.progress.iteration, 1'000'000);

  // The queued job never ran; the worker goes on with the next one.
  EXPECT_EQ(jobs->get(queued).started_at, 0);
  EXPECT_FALSE(fs::exists(job_dir(config_, queued)));
  const JobInfo next = wait_finished(*jobs, jobs->submit(tiny_spec(20)).id);
  EXPECT_EQ(job_state_name(next.state), std::string("succeeded")) << next.error;
  EXPECT_FALSE(fs::exists(fs::path(config_.model_store) / ("job-" + running)));

  for (const auto& [id, state] : {std::pair{running, "cancelled"}, std::pair{next.id, "succeeded"}}) {
    const std::string message = refusal([&] { jobs->cancel(id); }, ErrorCode::kFailedPrecondition, "id");
    EXPECT_NE(message.find(state), std::string::npos) << message;
  }
  auto counts = jobs->counts();
  EXPECT_EQ(counts[JobState::kCancelled], 2);
  EXPECT_EQ(counts[JobState::kSucceeded], 1);
}

TEST_F(TrainingJobsTest, AJobAtNormalPriorityRunsAtTheServersOwn) {
  config_.training_at_lowest_priority = false;
  auto jobs = make_jobs();
  const std::string running = jobs->submit(tiny_spec(1'000'000)).id;
  ASSERT_TRUE(eventually([&] { return jobs->get(running).progress.iteration >= 1; }, 180s))
      << job_state_name(jobs->get(running).state) << " " << jobs->get(running).error;
  const auto children = processes_mentioning(job_dir(config_, running).string());
  ASSERT_EQ(children.size(), 1u) << "the running job should have one child";
  const Scheduling server = scheduling_of(getpid()), child = scheduling_of(children[0]);
  EXPECT_EQ(child.nice, server.nice);
  EXPECT_EQ(child.policy, server.policy);
  EXPECT_NE(child.policy, "5") << "SCHED_IDLE";
  EXPECT_EQ(job_state_name(jobs->cancel(running).state), std::string("cancelled"));
}

TEST_F(TrainingJobsTest, JobResumedAfterTheServerWasKilledEndsWithTheUninterruptedModel) {
  const JobSpec spec = tiny_spec(100);
  const auto reference = uninterrupted_weights(spec);
  ASSERT_GE(reference.size(), 3u);

  // A server in a child process of its own, SIGKILLed once its job has a
  // checkpoint: nothing of it gets to clean up.
  const fs::path id_file = scratch_.path() / "job-id";
  const pid_t server = fork();
  ASSERT_GE(server, 0);
  if (server == 0) {
    try {
      TrainingJobs jobs(config_, nullptr);
      jobs.start();
      std::ofstream(id_file.string() + ".tmp") << jobs.submit(spec).id;
      fs::rename(id_file.string() + ".tmp", id_file);
      while (true) pause();
    } catch (...) {
      _exit(3);
    }
  }
  std::string id;
  ASSERT_TRUE(eventually([&] { return !(id = read_text(id_file)).empty(); }, 30s));
  const fs::path dir = job_dir(config_, id);
  const bool checkpointed = eventually([&] { return fs::exists(dir / "run" / "checkpoint.pt"); }, 180s);
  kill(server, SIGKILL);
  int status = 0;
  waitpid(server, &status, 0);
  ASSERT_TRUE(checkpointed);
  // The training child dies with its server (PR_SET_PDEATHSIG) at once; an
  // orphan would go on and export the model.
  EXPECT_TRUE(eventually([&] { return processes_mentioning(dir.string()).empty(); }, 5s)) << "orphaned training";
  ASSERT_FALSE(fs::exists(dir / "run" / "model" / "manifest.json")) << "the run went on after its server's kill";
  {
    SqliteJobStore store((fs::path(config_.state_dir) / "jobs.sqlite").string());
    EXPECT_EQ(job_state_name(store.find(id)->state), std::string("running"));
  }

  auto jobs = make_jobs();
  const JobInfo job = wait_finished(*jobs, id);
  ASSERT_EQ(job_state_name(job.state), std::string("succeeded")) << job.error;
  EXPECT_EQ(job.resumes, 1);
  EXPECT_EQ(job.progress.iteration, 100);
  const auto resumed = weight_files(fs::path(config_.model_store) / job.published_model);
  ASSERT_EQ(resumed.size(), reference.size());
  for (const auto& [name, bytes] : reference) {
    EXPECT_TRUE(resumed.at(name) == bytes) << name << " differs from the uninterrupted run's";
  }
}

TEST_F(TrainingJobsTest, ShutdownLeavesTheRunningJobQueuedAndARestartFinishesIt) {
  const JobSpec spec = tiny_spec(100);
  const auto reference = uninterrupted_weights(spec);
  ASSERT_GE(reference.size(), 3u);

  std::string id;
  {
    auto jobs = make_jobs();
    id = jobs->submit(spec).id;
    ASSERT_TRUE(eventually([&] { return jobs->get(id).progress.iteration >= 30; }, 180s));
    jobs->shutdown();
    const JobInfo stopped = jobs->get(id);  // records stay readable
    EXPECT_EQ(job_state_name(stopped.state), std::string("queued"));
    EXPECT_LT(stopped.progress.iteration, 100);
    EXPECT_TRUE(processes_mentioning(job_dir(config_, id).string()).empty()) << "shutdown left the child running";
    EXPECT_TRUE(fs::exists(job_dir(config_, id) / "run" / "checkpoint.pt"));
    refusal([&] { jobs->submit(spec); }, ErrorCode::kUnavailable, "");
    jobs->shutdown();  // idempotent
  }
  auto jobs = make_jobs();
  const JobInfo job = wait_finished(*jobs, id);
  ASSERT_EQ(job_state_name(job.state), std::string("succeeded")) << job.error;
  EXPECT_EQ(job.resumes, 1);
  EXPECT_EQ(job.progress.iteration, 100);
  const auto resumed = weight_files(fs::path(config_.model_store) / job.published_model);
  ASSERT_EQ(resumed.size(), reference.size());
  for (const auto& [name, bytes] : reference) {
    EXPECT_TRUE(resumed.at(name) == bytes) << name << " differs from the uninterrupted run's";
  }
}

}  // namespace
}  // namespace mm::service
