#include "drivers/tic/libusb_tic_transport.h"

#include <libusb.h>

#include <algorithm>

namespace mesocap::drivers::tic {
namespace {

// Pololu's own library waits 1600 ms: a Tic restoring its default settings
// takes up to 1500 ms to answer.
constexpr unsigned kTransferTimeoutMs = 1600;

// One libusb session; every transport and enumeration has its own, so
// nothing is shared between stages.
class LibusbSession {
 public:
  LibusbSession() {
    const int result = libusb_init(&context_);
    if (result != LIBUSB_SUCCESS) throw DeviceError(LibusbStartFailure(result));
  }
  ~LibusbSession() { libusb_exit(context_); }
  LibusbSession(const LibusbSession&) = delete;
  LibusbSession& operator=(const LibusbSession&) = delete;

  libusb_context* context() const { return context_; }

 private:
  libusb_context* context_ = nullptr;
};

// libusb's list of devices, freed (and unreferenced) on every path.
class DeviceList {
 public:
  explicit DeviceList(libusb_context* context) {
    const ssize_t count = libusb_get_device_list(context, &devices_);
    if (count < 0) ThrowLibusbError(static_cast<int>(count), "listing USB devices");
    count_ = static_cast<std::size_t>(count);
  }
  ~DeviceList() { libusb_free_device_list(devices_, 1); }
  DeviceList(const DeviceList&) = delete;
  DeviceList& operator=(const DeviceList&) = delete;

  std::span<libusb_device*> devices() const { return {devices_, count_}; }

 private:
  libusb_device** devices_ = nullptr;
  std::size_t count_ = 0;
};

std::string BusAddress(libusb_device* device) {
  return "bus " + std::to_string(libusb_get_bus_number(device)) + " address " +
         std::to_string(libusb_get_device_address(device));
}

// The serial number string descriptor, read through an open handle.
std::string ReadSerialNumber(libusb_device_handle* handle, const libusb_device_descriptor& descriptor) {
  if (descriptor.iSerialNumber == 0) return "";
  unsigned char text[256] = {};
  const int length = libusb_get_string_descriptor_ascii(handle, descriptor.iSerialNumber, text, sizeof(text) - 1);
  if (length < 0) ThrowLibusbError(length, "reading a Tic's serial number");
  return std::string(reinterpret_cast<const char*>(text), static_cast<std::size_t>(length));
}

struct FoundTic {
  TicDeviceInfo info;
  libusb_device* device = nullptr;  // owned by the DeviceList
};

// The Tics in `list`; a Tic whose serial cannot be read (no permission) is
// listed with the reason, so an open-by-serial error can name it.
std::vector<FoundTic> FindTics(const DeviceList& list) {
  std::vector<FoundTic> found;
  for (libusb_device* device : list.devices()) {
    libusb_device_descriptor descriptor{};
    if (libusb_get_device_descriptor(device, &descriptor) != LIBUSB_SUCCESS) continue;
    if (descriptor.idVendor != kPololuVendorId) continue;
    const std::optional<TicProduct> product = ProductFromUsbId(descriptor.idProduct);
    if (!product) continue;
    FoundTic tic;
    tic.device = device;
    tic.info.product = *product;
    tic.info.product_name = ProductName(*product);
    tic.info.bus_address = BusAddress(device);
    libusb_device_handle* handle = nullptr;
    const int opened = libusb_open(device, &handle);
    if (opened != LIBUSB_SUCCESS) {
      tic.info.problem = libusb_strerror(opened);
    } else {
      try {
        tic.info.serial_number = ReadSerialNumber(handle, descriptor);
      } catch (const DeviceError& e) {
        tic.info.problem = e.what();
      }
      libusb_close(handle);
    }
    found.push_back(std::move(tic));
  }
  return found;
}

class LibusbTicTransport : public TicTransport {
 public:
  LibusbTicTransport(std::unique_ptr<LibusbSession> session, libusb_device_handle* handle, TicDeviceInfo info)
      : session_(std::move(session)), handle_(handle), info_(std::move(info)) {}
  ~LibusbTicTransport() override { libusb_close(handle_); }
  LibusbTicTransport(const LibusbTicTransport&) = delete;
  LibusbTicTransport& operator=(const LibusbTicTransport&) = delete;

  const TicDeviceInfo& info() const override { return info_; }

  std::size_t ControlTransfer(const ControlSetup& setup, std::span<std::uint8_t> data) override {
    if (data.size() < setup.length) {
      throw DeviceError("Tic " + info_.serial_number + ": a control transfer of " + std::to_string(setup.length) +
                        " bytes with a buffer of " + std::to_string(data.size()));
    }
    const int result = libusb_control_transfer(handle_, setup.request_type, setup.request, setup.value, setup.index,
                                               data.data(), setup.length, kTransferTimeoutMs);
    if (result < 0) ThrowLibusbError(result, "Tic " + info_.serial_number + " request 0x" + Hex(setup.request));
    return static_cast<std::size_t>(result);
  }

 private:
  static std::string Hex(std::uint8_t byte) {
    const char* digits = "0123456789ABCDEF";
    return {digits[byte >> 4], digits[byte & 0xF]};
  }

  std::unique_ptr<LibusbSession> session_;  // outlives the handle: declared first
  libusb_device_handle* handle_;
  TicDeviceInfo info_;
};

}  // namespace

void ThrowLibusbError(int libusb_error, const std::string& doing) {
  const std::string message = doing + ": " + libusb_strerror(libusb_error);
  if (libusb_error == LIBUSB_ERROR_NO_DEVICE) throw DisconnectedError(message);
  if (libusb_error == LIBUSB_ERROR_TIMEOUT) throw TimeoutError(message);
  throw DeviceError(message);
}

std::string LibusbStartFailure(int libusb_error) {
  return std::string("libusb could not start (") + libusb_strerror(libusb_error) +
         "): no USB bus is visible to this process (is /dev/bus/usb there?)";
}

std::vector<TicDeviceInfo> ListLibusbTics() {
  LibusbSession session;
  DeviceList list(session.context());
  std::vector<TicDeviceInfo> tics;
  for (FoundTic& tic : FindTics(list)) tics.push_back(std::move(tic.info));
  return tics;
}

std::unique_ptr<TicTransport> OpenLibusbTic(const std::string& serial_number) {
  auto session = std::make_unique<LibusbSession>();
  DeviceList list(session->context());
  const std::vector<FoundTic> tics = FindTics(list);
  const auto match = std::find_if(tics.begin(), tics.end(),
                                  [&](const FoundTic& tic) { return tic.info.serial_number == serial_number; });
  if (match == tics.end()) {
    std::string found;
    for (const FoundTic& tic : tics) found += (found.empty() ? "" : "; ") + Describe(tic.info);
    throw DeviceError("no Tic with serial " + serial_number + " found (found: " + (found.empty() ? "none" : found) +
                      ")");
  }
  libusb_device_handle* handle = nullptr;
  const int opened = libusb_open(match->device, &handle);
  if (opened != LIBUSB_SUCCESS) ThrowLibusbError(opened, "opening " + Describe(match->info));
  return std::make_unique<LibusbTicTransport>(std::move(session), handle, match->info);
}

TicOpener LibusbTicOpener() {
  return [](const std::string& serial_number) { return OpenLibusbTic(serial_number); };
}

}  // namespace mesocap::drivers::tic
