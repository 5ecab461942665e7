// The vcam broker: owns the virtual devices of one `camlab vcam run` and serves them to
// every process of it over an AF_UNIX socket (protocol: broker_protocol.h), so that all
// processes see one device: a control set by one v4l2-ctl is read by the next, and one
// process streaming makes the queue busy for the others, as with a kernel driver.
//
// One thread accepts; one thread per connection (= per open file) serves its requests.
// No request blocks in the broker: blocking DQBUF and poll waits happen in the client on
// the file's readiness eventfd, so a slow client never holds up another.
//
// Buffers are the devices' memfds, passed to clients by SCM_RIGHTS and mapped there:
// frames reach a client without a copy.
//
// Thread-safe. Destruction stops accepting, closes every connection (releasing its open
// file and mappings) and joins the threads.
#pragma once

#include <atomic>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "base/result.h"
#include "base/unique_fd.h"
#include "mock_device/v4l2/virtual_media_device.h"
#include "mock_device/v4l2/virtual_v4l2_device.h"

namespace camlab::mock {

class VcamBroker {
 public:
  // Listens on `socket_path` (created; must not exist). devices[i] is served as
  // /dev/video<devices[i]->index()>, with its media controller node as
  // /dev/media<index> (make_media_device_for()).
  static Result<std::unique_ptr<VcamBroker>> start(
      std::vector<std::shared_ptr<VirtualV4l2Device>> devices, const std::string& socket_path);
  ~VcamBroker();
  VcamBroker(const VcamBroker&) = delete;
  VcamBroker& operator=(const VcamBroker&) = delete;

  const std::string& socket_path() const { return socket_path_; }
  // Connections (open files) now served, for leak checks.
  size_t open_file_count() const;
  const std::vector<std::shared_ptr<VirtualV4l2Device>>& devices() const { return devices_; }
  // The media node of /dev/video<index>, or null.
  std::shared_ptr<VirtualMediaDevice> media_device(int index) const;

 private:
  struct Connection {
    UniqueFd socket;
    std::thread thread;
    std::atomic<bool> finished{false};
  };
  VcamBroker(std::vector<std::shared_ptr<VirtualV4l2Device>> devices, std::string socket_path,
             UniqueFd listen_fd);
  void accept_loop();
  void serve(Connection* connection);
  void reap_finished();  // joins connections whose client went away; call with mutex_ held

  std::vector<std::shared_ptr<VirtualV4l2Device>> devices_;
  // One per media node: the device and the memfd whose open file descriptions are the
  // clients' fds of it (one inode per node, so lockf() excludes across processes).
  struct MediaNode {
    std::shared_ptr<VirtualMediaDevice> device;
    UniqueFd memfd;
  };
  std::vector<MediaNode> media_;
  std::string socket_path_;
  UniqueFd listen_fd_;
  std::atomic<bool> stopping_{false};
  mutable std::mutex mutex_;
  std::list<Connection> connections_;
  std::thread acceptor_;
};

}  // namespace camlab::mock
