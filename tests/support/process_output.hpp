// Test helpers for killing and starving the real CLI: fork/exec of vim-pipeline (optionally with a
// file-size limit, RLIMIT_FSIZE, set in the child before exec) or of any program (mpirun), SIGKILL of
// a whole process tree, the exit status or signal, and a check that every file left under a final name
// is complete of its kind.
#pragma once

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <vtkNew.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "run_cli.hpp"  // slurp

namespace vim::test {

namespace fs = std::filesystem;

struct ProcessResult {
  int code = -1;    // exit status, or -1 when killed by a signal
  int signal = 0;   // terminating signal, if any
  std::string err;  // everything the CLI wrote to stderr
};

// fork/exec of argv[0] (a path) with stdout to /dev/null and stderr to `err_file`; file_size_limit >= 0
// sets RLIMIT_FSIZE (bytes) in the child, with SIGXFSZ ignored (a full disk, without privileges).
inline pid_t spawn_process(std::vector<std::string> argv_s, const fs::path& err_file,
                           long file_size_limit = -1) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int out = ::open("/dev/null", O_WRONLY);
    const int err = ::open(err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (out >= 0) ::dup2(out, 1);
    if (err >= 0) ::dup2(err, 2);
    if (file_size_limit >= 0) {
      const rlimit lim{static_cast<rlim_t>(file_size_limit), static_cast<rlim_t>(file_size_limit)};
      ::setrlimit(RLIMIT_FSIZE, &lim);
      ::signal(SIGXFSZ, SIG_IGN);  // write() then fails with EFBIG instead of killing the process
    }
    std::vector<char*> argv;
    for (auto& s : argv_s) argv.push_back(s.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

// spawn_process of vim-pipeline with `args`.
inline pid_t spawn_cli(const std::vector<std::string>& args, const fs::path& err_file,
                       long file_size_limit = -1) {
  std::vector<std::string> argv_s{VIM_PIPELINE_EXE};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  return spawn_process(std::move(argv_s), err_file, file_size_limit);
}

inline ProcessResult wait_cli(pid_t pid, const fs::path& err_file) {
  ProcessResult r;
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (WIFEXITED(status)) r.code = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) r.signal = WTERMSIG(status);
  r.err = slurp(err_file);
  return r;
}

// Runs the CLI with `args` to its end (spawn_cli, wait_cli).
inline ProcessResult run_to_end(const std::vector<std::string>& args, const fs::path& err_file,
                                long file_size_limit = -1) {
  return wait_cli(spawn_cli(args, err_file, file_size_limit), err_file);
}

// `root` and every process below it (parent links read from /proc/PID/stat).
inline std::vector<pid_t> process_tree(pid_t root) {
  std::vector<std::pair<pid_t, pid_t>> parent_of;  // {pid, ppid}
  for (const auto& e : fs::directory_iterator("/proc")) {
    const std::string name = e.path().filename().string();
    if (name.empty() ||
        !std::all_of(name.begin(), name.end(), [](unsigned char c) { return std::isdigit(c) != 0; }))
      continue;
    const std::string stat = slurp(e.path() / "stat");  // "pid (comm) state ppid ..."
    const auto close = stat.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(stat.substr(close + 1));
    char state = 0;
    long ppid = 0;
    if (rest >> state >> ppid)
      parent_of.emplace_back(static_cast<pid_t>(std::stol(name)), static_cast<pid_t>(ppid));
  }
  std::vector<pid_t> tree{root};
  for (std::size_t at = 0; at < tree.size(); ++at)
    for (const auto& [pid, ppid] : parent_of)
      if (ppid == tree[at]) tree.push_back(pid);
  return tree;
}

// True while `pid` runs (not exited, not a zombie).
inline bool running(pid_t pid) {
  const std::string stat = slurp(fs::path("/proc") / std::to_string(pid) / "stat");
  const auto close = stat.rfind(')');
  return close != std::string::npos && close + 2 < stat.size() && stat[close + 2] != 'Z';
}

// SIGKILL to `root` and every process below it (a job killed whole: mpirun and its ranks), then waits
// (at most 10 s) until none of them runs any more; the caller still reaps `root` (wait_cli).
inline void kill_tree(pid_t root) {
  const std::vector<pid_t> tree = process_tree(root);
  for (const pid_t pid : tree) ::kill(pid, SIGKILL);
  for (int waited = 0; waited < 1000; ++waited) {
    if (std::none_of(tree.begin() + 1, tree.end(), running)) break;
    ::usleep(10000);
  }
}

// Files in `dir` (recursively) with a final name: not hidden temporaries (".NAME.PID.N.partial",
// ".NAME.tmpPID_N.EXT").
inline std::vector<fs::path> final_files(const fs::path& dir) {
  std::vector<fs::path> files;
  if (!fs::exists(dir)) return files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::string name = e.path().filename().string();
    if (name.empty() || name[0] == '.' || e.path().extension() == ".partial") continue;
    files.push_back(e.path());
  }
  return files;
}

inline std::string rtrim(std::string s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  return s;
}

inline bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// Empty string when `p` is a complete file of its kind, else what is wrong with it.
inline std::string incomplete_reason(const fs::path& p) {
  const std::string text = slurp(p);
  const std::string ext = p.extension().string();
  if (rtrim(text).empty()) return "empty";
  if (ext == ".json") {
    try {
      const auto parsed = nlohmann::json::parse(text);
      if (parsed.is_discarded()) return "json discarded";
    } catch (const std::exception& e) {
      return std::string("json does not parse: ") + e.what();
    }
  } else if (ext == ".vtu") {
    if (!ends_with(rtrim(text), "</VTKFile>")) return "vtu does not end with </VTKFile>";
    vtkNew<vtkXMLUnstructuredGridReader> reader;
    reader->SetFileName(p.c_str());
    reader->Update();
    if (reader->GetErrorCode() != 0 || reader->GetOutput() == nullptr)
      return "vtkXMLUnstructuredGridReader fails";
  } else if (ext == ".pvtu") {
    // Complete when it is whole XML and every piece it names is a complete .vtu beside it.
    if (!ends_with(rtrim(text), "</VTKFile>")) return "pvtu does not end with </VTKFile>";
    const std::string key = "<Piece Source=\"";
    for (auto at = text.find(key); at != std::string::npos; at = text.find(key, at + 1)) {
      const auto from = at + key.size();
      const fs::path piece = p.parent_path() / text.substr(from, text.find('"', from) - from);
      if (!fs::exists(piece)) return "pvtu names a missing piece " + piece.string();
      const std::string why = incomplete_reason(piece);
      if (!why.empty()) return "piece " + piece.string() + ": " + why;
    }
  } else if (ext == ".pvd" || ext == ".feb" || ext == ".xml") {
    if (rtrim(text).back() != '>') return "xml file ends mid-element";
  } else if (ext == ".csv") {
    if (text.back() != '\n') return "csv ends in the middle of a line";
    std::istringstream in(text);
    std::string line;
    std::size_t columns = 0;
    while (std::getline(in, line)) {
      const std::size_t c = std::count(line.begin(), line.end(), ',') + 1;
      if (columns == 0) columns = c;
      if (c != columns)
        return "csv line with " + std::to_string(c) + " columns, header has " + std::to_string(columns);
    }
  } else if (ext == ".png") {
    // The last chunk of a PNG is IEND: length 0, "IEND", 4-byte CRC.
    if (text.size() < 12 || text.compare(text.size() - 8, 4, "IEND") != 0)
      return "png does not end with IEND";
  } else if (ext == ".msh") {
    const std::string t = rtrim(text);
    if (t.compare(t.rfind('\n') + 1, 4, "$End") != 0) return "msh does not end with an $End* line";
  }
  return "";
}

// Kills the job started as `pid` (it and every process below it) `at` seconds from now, reaps it, and
// expects every file left under a final name in `out` to be complete; returns how many there are.
inline long kill_and_count_complete_files(pid_t pid, double at, double duration, const fs::path& err_file,
                                          const fs::path& out) {
  std::this_thread::sleep_for(std::chrono::duration<double>(at));
  kill_tree(pid);
  wait_cli(pid, err_file);
  SCOPED_TRACE("killed after " + std::to_string(at) + " s of a " + std::to_string(duration) + " s run");
  long left = 0;
  for (const auto& f : final_files(out)) {
    ++left;
    EXPECT_EQ(incomplete_reason(f), "") << f;
  }
  return left;
}

}  // namespace vim::test
