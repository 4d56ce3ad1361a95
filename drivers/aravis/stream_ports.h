// The UDP ports the streams of one rig's GigE Vision cameras receive on.
// Aravis binds a stream's socket with SO_REUSEADDR and SO_REUSEPORT, so the
// kernel may give a new stream the port of one still open (about 1 in 7000
// bindings here). Where Aravis receives on that socket (a process without
// CAP_NET_RAW has no packet socket), the kernel then hands each camera's
// packets to either socket, and a camera's frame can complete on the other
// camera's stream. A camera whose new stream got a port another camera
// holds makes the stream again.
#pragma once

#include <cstdint>
#include <mutex>
#include <set>

namespace mesocap::drivers::aravis {

class StreamPorts {
 public:
  // True, and the port held, when no other stream holds it.
  bool Claim(std::uint16_t port) {
    std::lock_guard lock(mutex_);
    return held_.insert(port).second;
  }
  void Release(std::uint16_t port) {
    std::lock_guard lock(mutex_);
    held_.erase(port);
  }

 private:
  std::mutex mutex_;
  std::set<std::uint16_t> held_;
};

}  // namespace mesocap::drivers::aravis
