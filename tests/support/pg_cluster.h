// A throwaway PostgreSQL cluster for tests and benchmarks: a data folder in a fresh
// temporary folder, a server on 127.0.0.1 and a free port (and its Unix socket in that
// folder), stopped and removed when the PgCluster goes, and also when the test process
// dies without running destructors (a reaper process waits for the test's end on a pipe).
//
// PostgreSQL's initdb and postgres refuse to run as root (tests and CI run as root): then
// the folder is given to the `postgres` user and every server command runs through
// `runuser -u postgres --`. The server binaries are looked for in /usr/lib/postgresql/*/bin
// (scripts/install-deps.sh installs postgresql-15); a test skips, saying so, only when
// they are absent.
//
// initdb takes seconds, so its output is made once per PostgreSQL version and user into
// a template folder in the temporary folder (under a lock) and copied for each cluster.
//
// Thread-compatible.
#pragma once

#include <fcntl.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace camlab::testing {

namespace pg_detail {

namespace fs = std::filesystem;

inline std::string slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Runs argv with stdout and stderr into `log`, waiting at most `timeout`; the exit status,
// or -1 when it could not run or took too long (then it is killed).
inline int run(const std::vector<std::string>& argv, const fs::path& log,
               std::chrono::seconds timeout = std::chrono::seconds(60)) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                   O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::vector<std::string> copy = argv;
  std::vector<char*> cargv;
  for (auto& a : copy) cargv.push_back(a.data());
  cargv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, cargv[0], &actions, nullptr, cargv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) return -1;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  int status = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    if (waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ::kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return -1;
}

inline int free_loopback_port() {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t size = sizeof addr;
  int port = 0;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0 &&
      ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &size) == 0)
    port = ntohs(addr.sin_port);
  ::close(fd);
  return port;
}

}  // namespace pg_detail

class PgCluster {
 public:
  // The folder of initdb, pg_ctl, postgres and psql (the newest version installed), or
  // empty.
  static std::filesystem::path binaries() {
    std::filesystem::path best;
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator("/usr/lib/postgresql", ec)) {
      const auto bin = entry.path() / "bin";
      if (std::filesystem::exists(bin / "initdb") && std::filesystem::exists(bin / "pg_ctl") &&
          std::filesystem::exists(bin / "postgres") && (best.empty() || bin > best))
        best = bin;
    }
    return best;
  }
  // Why no cluster can be started here ("" when one can): the skip message.
  static std::string missing() {
    if (!binaries().empty()) return "";
    return "PostgreSQL's server binaries (initdb, pg_ctl, postgres under "
           "/usr/lib/postgresql/VERSION/bin) are not installed; scripts/install-deps.sh "
           "installs postgresql-15";
  }

  PgCluster() = default;
  PgCluster(const PgCluster&) = delete;
  PgCluster& operator=(const PgCluster&) = delete;
  ~PgCluster() { remove(); }

  // Makes and starts the cluster; false with the reason in `error`. `durable`: fsync and
  // synchronous commit as PostgreSQL ships (benchmarks); otherwise off (tests: a machine
  // crash is not what they test, and syncing costs seconds).
  bool start(std::string* error, bool durable = false) {
    bin_ = binaries();
    if (bin_.empty()) return fail(error, missing());
    as_root_ = ::geteuid() == 0;
    std::string pattern = (std::filesystem::temp_directory_path() / "camlab_pg_XXXXXX").string();
    if (!::mkdtemp(pattern.data())) return fail(error, "mkdtemp failed");
    dir_ = pattern;
    if (as_root_ && !give_to_postgres(dir_)) return fail(error, "no user 'postgres' to run as");
    start_reaper();
    const std::filesystem::path data = dir_ / "data";
    std::string template_error;
    const std::filesystem::path made = template_folder(&template_error);
    if (made.empty()) return fail(error, template_error);
    if (pg_detail::run({"cp", "-a", made.string(), data.string()}, dir_ / "setup.log") != 0)
      return fail(error, "copying the initdb template failed: " + log("setup.log"));
    std::string options =
        "-c listen_addresses=127.0.0.1 -c unix_socket_directories=" + dir_.string() +
        " -c max_connections=200";
    if (!durable) options += " -c fsync=off -c synchronous_commit=off -c full_page_writes=off";
    for (int attempt = 0; attempt < 3; ++attempt) {
      port_ = pg_detail::free_loopback_port();
      options_ = options + " -c port=" + std::to_string(port_);
      if (resume()) return true;
    }
    return fail(error, "pg_ctl start failed: " + log("pg_ctl.log") + log("server.log"));
  }

  // pg_ctl restart -m fast: every connection is closed, the server comes back on the
  // same port. False if it did not come back.
  bool restart() {
    return server({"-D", (dir_ / "data").string(), "-l", (dir_ / "server.log").string(), "-m",
                   "fast", "-w", "-t", "60", "restart"}) == 0;
  }
  bool stop() {
    return server({"-D", (dir_ / "data").string(), "-m", "fast", "-w", "-t", "60", "stop"}) == 0;
  }
  // Starts it again after stop(), as it was.
  bool resume() {
    return server({"-D", (dir_ / "data").string(), "-l", (dir_ / "server.log").string(), "-w", "-t",
                   "60", "-o", options_, "start"}) == 0;
  }

  // Runs SQL through psql as the superuser; its output, or "" with `ok` false.
  std::string sql(const std::string& database, const std::string& statement, bool* ok = nullptr) {
    const std::filesystem::path out = dir_ / "psql.out";
    std::filesystem::remove(out);
    const int rc =
        pg_detail::run({(bin_ / "psql").string(), "-X", "-q", "-A", "-t", "-v", "ON_ERROR_STOP=1",
                        "-h", "127.0.0.1", "-p", std::to_string(port_), "-U", "postgres", "-d",
                        database, "-c", statement},
                       out);
    if (ok) *ok = rc == 0;
    return pg_detail::slurp(out);
  }
  bool create_database(const std::string& name) {
    bool ok = false;
    sql("postgres", "CREATE DATABASE " + name, &ok);
    return ok;
  }

  // A libpq URL of `database` as the superuser (trust authentication on loopback).
  std::string url(const std::string& database) const {
    return "postgresql://postgres@127.0.0.1:" + std::to_string(port_) + "/" + database;
  }
  int port() const { return port_; }
  const std::filesystem::path& dir() const { return dir_; }
  std::string server_log() const { return pg_detail::slurp(dir_ / "server.log"); }

 private:
  bool fail(std::string* error, const std::string& why) {
    if (error) *error = why;
    remove();
    return false;
  }
  std::string log(const char* name) const { return pg_detail::slurp(dir_ / name); }

  std::vector<std::string> as_postgres(std::vector<std::string> argv) const {
    if (as_root_) argv.insert(argv.begin(), {"runuser", "-u", "postgres", "--"});
    return argv;
  }
  int server(std::vector<std::string> args) {
    args.insert(args.begin(), (bin_ / "pg_ctl").string());
    return pg_detail::run(as_postgres(args), dir_ / "pg_ctl.log", std::chrono::seconds(90));
  }

  static bool give_to_postgres(const std::filesystem::path& path) {
    const passwd* user = ::getpwnam("postgres");
    return user && ::chown(path.c_str(), user->pw_uid, user->pw_gid) == 0;
  }

  // initdb's output for this version and user, made once (under a lock) and reused.
  std::filesystem::path template_folder(std::string* error) {
    const std::string version = bin_.parent_path().filename().string();
    const std::filesystem::path folder =
        std::filesystem::temp_directory_path() /
        ("camlab_pg_template_" + version + "_uid" + std::to_string(::geteuid()));
    if (std::filesystem::exists(folder / "PG_VERSION")) return folder;
    const std::string lock_path = folder.string() + ".lock";
    const int lock = ::open(lock_path.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0600);
    if (lock < 0 || ::flock(lock, LOCK_EX) != 0) {
      if (lock >= 0) ::close(lock);
      *error = "cannot lock " + lock_path;
      return {};
    }
    std::filesystem::path made = folder;
    if (!std::filesystem::exists(folder / "PG_VERSION")) {
      const std::filesystem::path scratch = dir_ / "template";
      if (pg_detail::run(
              as_postgres({(bin_ / "initdb").string(), "-D", scratch.string(), "-U", "postgres",
                           "--auth=trust", "-E", "UTF8", "--no-locale", "-N"}),
              dir_ / "initdb.log") != 0 ||
          pg_detail::run({"cp", "-a", scratch.string(), folder.string() + ".tmp"},
                         dir_ / "setup.log") != 0) {
        *error = "initdb failed: " + log("initdb.log") + log("setup.log");
        made.clear();
      } else {
        std::filesystem::rename(folder.string() + ".tmp", folder);
      }
    }
    ::flock(lock, LOCK_UN);
    ::close(lock);
    return made;
  }

  // A child that waits for this process to close a pipe (its destructor, or its death),
  // then stops the server at once and removes the folder.
  void start_reaper() {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) return;
    const std::string stop = (as_root_ ? "runuser -u postgres -- " : "") +
                             (bin_ / "pg_ctl").string() + " -D '" + (dir_ / "data").string() +
                             "' -m immediate -w stop >/dev/null 2>&1; rm -rf '" + dir_.string() +
                             "'";
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[0], STDIN_FILENO);
    const std::string script = "read -r ignored; " + stop;
    std::vector<std::string> argv = {"/bin/sh", "-c", script};
    std::vector<char*> cargv;
    for (auto& a : argv) cargv.push_back(a.data());
    cargv.push_back(nullptr);
    // Its own process group: a signal to the test's group (ctest's timeout) spares it.
    posix_spawnattr_t attr;
    posix_spawnattr_init(&attr);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attr, 0);
    if (posix_spawn(&reaper_, "/bin/sh", &actions, &attr, cargv.data(), environ) != 0) reaper_ = -1;
    posix_spawnattr_destroy(&attr);
    posix_spawn_file_actions_destroy(&actions);
    ::close(fds[0]);
    reaper_pipe_ = fds[1];
  }

  void remove() {
    if (reaper_pipe_ >= 0) {
      ::close(reaper_pipe_);  // the reaper stops the server and removes the folder
      reaper_pipe_ = -1;
      int status = 0;
      if (reaper_ > 0) waitpid(reaper_, &status, 0);
      reaper_ = -1;
    } else if (!dir_.empty()) {
      std::error_code ec;
      std::filesystem::remove_all(dir_, ec);
    }
    dir_.clear();
  }

  std::filesystem::path bin_, dir_;
  std::string options_;  // the server's settings (port, socket folder, durability)
  bool as_root_ = false;
  int port_ = 0;
  pid_t reaper_ = -1;
  int reaper_pipe_ = -1;
};

}  // namespace camlab::testing
