#include "obm/obmnet/distributed.hpp"

#include <torch/csrc/distributed/c10d/FileStore.hpp>
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>
#include <torch/torch.h>

#include <chrono>
#include <cstdlib>
#include <map>

#include "obm/core/errors.hpp"
#include "obm/core/log.hpp"
#include "obm/obmnet/collectives.hpp"

namespace obm::obmnet {

namespace {

int envInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  if (v == nullptr || *v == '\0') return fallback;
  char* end = nullptr;
  const long x = std::strtol(v, &end, 10);
  if (end == v || *end != '\0')
    throw ConfigError(std::string("environment variable ") + name + "='" + v +
                      "': not an integer");
  return static_cast<int>(x);
}

std::string envString(const char* name, const std::string& fallback) {
  const char* v = std::getenv(name);
  return (v == nullptr || *v == '\0') ? fallback : std::string(v);
}

std::string errorText(const std::exception& e) {
  if (const auto* c = dynamic_cast<const c10::Error*>(&e)) return c->what_without_backtrace();
  return e.what();
}

bool isLoopback(const std::string& addr) {
  return addr == "localhost" || addr.rfind("127.", 0) == 0 || addr == "::1";
}

}  // namespace

DistributedOptions DistributedOptions::fromEnvironment() {
  DistributedOptions o;
  o.world_size = envInt("WORLD_SIZE", 1);
  o.rank = envInt("RANK", 0);
  o.master_addr = envString("MASTER_ADDR", o.master_addr);
  o.master_port = envInt("MASTER_PORT", o.master_port);
  o.init_file = envString("OBM_DIST_FILE", "");
  const std::string t = envString("OBM_DIST_TIMEOUT", "");
  if (!t.empty()) {
    char* end = nullptr;
    o.timeout_s = std::strtod(t.c_str(), &end);
    if (end == t.c_str() || *end != '\0')
      throw ConfigError("environment variable OBM_DIST_TIMEOUT='" + t + "': not a number");
  }
  o.validate();
  return o;
}

void DistributedOptions::validate() const {
  if (world_size < 1) throw ConfigError("WORLD_SIZE=" + std::to_string(world_size) + ": must be >= 1");
  if (rank < 0 || rank >= world_size)
    throw ConfigError("RANK=" + std::to_string(rank) + ": must be in [0, WORLD_SIZE = " +
                      std::to_string(world_size) + ")");
  if (init_file.empty() && (master_port < 1 || master_port > 65535))
    throw ConfigError("MASTER_PORT=" + std::to_string(master_port) + ": must be in [1, 65535]");
  if (!(timeout_s > 0)) throw ConfigError("OBM_DIST_TIMEOUT: must be > 0 seconds");
}

struct ProcessGroup::Impl {
  DistributedOptions opt;
  c10::intrusive_ptr<c10d::ProcessGroupGloo> pg;

  std::string who() const {
    return "distributed training: rank " + std::to_string(opt.rank) + " of " +
           std::to_string(opt.world_size);
  }

  /// Runs one collective; a failure (a peer gone, a timeout) becomes an obm::Error that says so.
  template <class F>
  void run(const char* what, F&& f) {
    try {
      f()->wait();
    } catch (const std::exception& e) {
      throw Error(who() + ": " + what + " failed: a peer process has exited or did not answer " +
                  "within " + std::to_string(static_cast<long>(opt.timeout_s)) + " s (" +
                  errorText(e) + ")");
    }
  }
};

ProcessGroup::ProcessGroup(const DistributedOptions& options) : impl_(std::make_unique<Impl>()) {
  options.validate();
  impl_->opt = options;
  const auto timeout =
      std::chrono::milliseconds(static_cast<std::int64_t>(options.timeout_s * 1000.0));
  const std::string where = options.init_file.empty()
                                ? options.master_addr + ":" + std::to_string(options.master_port)
                                : "file " + options.init_file;
  try {
    c10::intrusive_ptr<c10d::Store> store;
    if (!options.init_file.empty()) {
      store = c10::make_intrusive<c10d::FileStore>(options.init_file, options.world_size);
    } else {
      c10d::TCPStoreOptions so;
      so.port = static_cast<std::uint16_t>(options.master_port);
      so.isServer = options.rank == 0;
      so.numWorkers = static_cast<std::size_t>(options.world_size);
      so.waitWorkers = true;
      so.timeout = timeout;
      store = c10::make_intrusive<c10d::TCPStore>(options.master_addr, so);
    }
    auto go = c10d::ProcessGroupGloo::Options::create(timeout);
    // The interface Gloo binds: GLOO_SOCKET_IFNAME as in PyTorch; loopback for a one-machine
    // run; else the address this machine's host name resolves to.
    const std::string ifname = envString("GLOO_SOCKET_IFNAME", "");
    if (!ifname.empty())
      go->devices.push_back(c10d::ProcessGroupGloo::createDeviceForInterface(ifname));
    else if (options.init_file.empty() && isLoopback(options.master_addr))
      go->devices.push_back(c10d::ProcessGroupGloo::createDeviceForHostname("127.0.0.1"));
    else
      go->devices.push_back(c10d::ProcessGroupGloo::createDefaultDevice());
    impl_->pg = c10::make_intrusive<c10d::ProcessGroupGloo>(store, options.rank,
                                                             options.world_size, go);
  } catch (const std::exception& e) {
    throw Error(impl_->who() + ": rendezvous at " + where + " failed (" + errorText(e) + ")");
  }
  OBM_LOG_INFO("obm-train", impl_->who() << ": joined at " << where);
}

ProcessGroup::~ProcessGroup() = default;

int ProcessGroup::rank() const {
  return impl_->opt.rank;
}
int ProcessGroup::worldSize() const {
  return impl_->opt.world_size;
}
const DistributedOptions& ProcessGroup::options() const {
  return impl_->opt;
}

void ProcessGroup::allReduceSum(std::vector<double>& values) {
  if (values.empty()) return;
  auto t = torch::tensor(values, torch::kFloat64);
  std::vector<torch::Tensor> v{t};
  impl_->run("all-reduce", [&] { return impl_->pg->allreduce(v); });
  for (std::size_t i = 0; i < values.size(); ++i)
    values[i] = t[static_cast<int64_t>(i)].item<double>();
}

void ProcessGroup::barrier() {
  impl_->run("barrier", [&] { return impl_->pg->barrier(); });
}

void allReduceGradients(ProcessGroup& group, const std::vector<torch::Tensor>& parameters,
                        int local_pairs, int global_pairs) {
  if (global_pairs <= 0) throw ContractError("allReduceGradients: global_pairs must be > 0");
  torch::NoGradGuard ng;
  const double scale = static_cast<double>(local_pairs) / static_cast<double>(global_pairs);
  std::vector<torch::Tensor> parts;
  parts.reserve(parameters.size());
  for (const auto& p : parameters) {
    if (p.grad().defined())
      parts.push_back(p.grad().detach().to(torch::kFloat32).flatten() * scale);
    else
      parts.push_back(torch::zeros({p.numel()}, torch::kFloat32));
  }
  if (parts.empty()) return;
  auto flat = torch::cat(parts);
  std::vector<torch::Tensor> v{flat};
  group.impl().run("gradient all-reduce", [&] { return group.impl().pg->allreduce(v); });
  int64_t offset = 0;
  for (const auto& p : parameters) {
    const int64_t n = p.numel();
    auto slice = flat.narrow(0, offset, n).view(p.sizes()).to(p.dtype());
    auto& g = const_cast<torch::Tensor&>(p).mutable_grad();
    if (g.defined())
      g.copy_(slice);
    else
      g = slice.clone();
    offset += n;
  }
}

void broadcastTensors(ProcessGroup& group, const std::vector<torch::Tensor>& tensors, int root) {
  torch::NoGradGuard ng;
  // One broadcast per dtype: the tensors flattened into one buffer and copied back.
  std::map<int, std::vector<torch::Tensor>> by_type;
  for (const auto& t : tensors)
    if (t.defined() && t.numel() > 0)
      by_type[static_cast<int>(t.scalar_type())].push_back(t);
  for (auto& [type, ts] : by_type) {
    std::vector<torch::Tensor> flat_parts;
    for (const auto& t : ts) flat_parts.push_back(t.detach().reshape({-1}));
    auto flat = torch::cat(flat_parts).contiguous();
    std::vector<torch::Tensor> v{flat};
    c10d::BroadcastOptions bo;
    bo.rootRank = root;
    group.impl().run("broadcast", [&] { return group.impl().pg->broadcast(v, bo); });
    int64_t offset = 0;
    for (auto& t : ts) {
      const int64_t n = t.numel();
      const_cast<torch::Tensor&>(t).detach().copy_(flat.narrow(0, offset, n).view(t.sizes()));
      offset += n;
    }
  }
}

}  // namespace obm::obmnet
