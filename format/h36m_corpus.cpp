#include "format/h36m_corpus.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <filesystem>
#include <thread>
#include <tuple>

#include "format/input_error.h"
#include "format/motion_text.h"

namespace mm {

namespace fs = std::filesystem;

const std::vector<std::string>& h36m_actions() {
  static const std::vector<std::string> actions = {
      "walking",  "eating",     "smoking",     "discussion", "directions",
      "greeting", "phoning",    "posing",      "purchases",  "sitting",
      "sittingdown", "takingphoto", "waiting", "walkingdog", "walkingtogether"};
  return actions;
}

namespace {

bool has_subject_folders(const fs::path& dir) {
  std::error_code error;
  for (const char* subject : {"S1", "S5", "S6", "S7", "S8", "S9", "S11"}) {
    if (fs::is_directory(dir / subject, error)) return true;
  }
  return false;
}

// "S11" -> 11 so that S5 sorts before S11; other names sort after, by text.
std::tuple<int, std::string> subject_key(const std::string& subject) {
  if (subject.size() > 1 && subject[0] == 'S' &&
      std::all_of(subject.begin() + 1, subject.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
      subject.size() < 10) {
    return {std::stoi(subject.substr(1)), subject};
  }
  return {1 << 30, subject};
}

struct FileJob {
  std::string subject;
  std::string action;
  int take;
  std::string path;
};

}  // namespace

std::string resolve_h36m_dataset_dir(const std::string& dir) {
  const fs::path root(dir);
  for (const fs::path& candidate : {root, root / "h3.6m" / "dataset", root / "dataset"}) {
    if (has_subject_folders(candidate)) return candidate.string();
  }
  throw InputError(dir + ": no H3.6M data set found, expected S1, S5, ... folders in it, in "
                   "h3.6m/dataset or in dataset below it");
}

std::vector<MotionSequence> load_h36m_corpus(const std::string& dir,
                                             const std::vector<std::string>& subjects,
                                             int downsample) {
  if (downsample < 1) {
    throw InputError("load_h36m_corpus", "downsample " + std::to_string(downsample) +
                     " is invalid, expected an integer >= 1");
  }
  const fs::path dataset(resolve_h36m_dataset_dir(dir));
  std::vector<FileJob> jobs;
  for (const std::string& subject : subjects) {
    if (subject.empty() || subject.find_first_of("/\\") != std::string::npos || subject == "." ||
        subject == "..") {
      throw InputError("load_h36m_corpus", "subject \"" + subject +
                       "\" is not a folder name like \"S1\"");
    }
    std::error_code error;
    if (!fs::is_directory(dataset / subject, error)) {
      throw InputError((dataset / subject).string() + ": subject folder does not exist");
    }
    for (const std::string& action : h36m_actions()) {
      for (int take = 1; take <= 2; ++take) {
        const fs::path path = dataset / subject / (action + "_" + std::to_string(take) + ".txt");
        // Copies of the data set may lack some long files; skipping them
        // keeps every present file usable.
        if (fs::is_regular_file(path, error)) jobs.push_back({subject, action, take, path.string()});
      }
    }
  }

  std::vector<std::vector<MotionSequence>> results(jobs.size());
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  std::vector<std::exception_ptr> errors(jobs.size());
  auto worker = [&]() {
    for (size_t j = next.fetch_add(1); j < jobs.size() && !failed; j = next.fetch_add(1)) {
      try {
        const FileJob& job = jobs[j];
        std::vector<MotionFrames> phases = split_phases(read_motion_text(job.path), downsample);
        for (int phase = 0; phase < downsample; ++phase) {
          results[j].push_back(MotionSequence{job.subject, job.action, job.take, phase,
                                              std::move(phases[static_cast<size_t>(phase)])});
        }
      } catch (...) {
        errors[j] = std::current_exception();
        failed = true;
      }
    }
  };
  // Parsing is CPU-bound; a few threads saturate the 2-core CI machine and
  // typical disks without oversubscribing larger hosts' memory bandwidth.
  const unsigned hardware = std::max(1u, std::thread::hardware_concurrency());
  const size_t thread_count = std::min<size_t>({hardware, 4u, std::max<size_t>(jobs.size(), 1)});
  std::vector<std::thread> threads;
  for (size_t t = 1; t < thread_count; ++t) threads.emplace_back(worker);
  worker();
  for (std::thread& thread : threads) thread.join();
  // Report the first failing file in job order so the message is deterministic.
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);
  }

  std::vector<MotionSequence> sequences;
  for (std::vector<MotionSequence>& file : results) {
    for (MotionSequence& sequence : file) sequences.push_back(std::move(sequence));
  }
  std::sort(sequences.begin(), sequences.end(), [](const MotionSequence& a, const MotionSequence& b) {
    return std::make_tuple(subject_key(a.subject), a.action, a.take, a.phase) <
           std::make_tuple(subject_key(b.subject), b.action, b.take, b.phase);
  });
  return sequences;
}

}  // namespace mm
