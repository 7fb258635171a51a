// direct-transfer: copies named arrays from one solver's outputs to another's
// inputs unchanged, for interfaces whose discretisations coincide (and for
// testing the exchange machinery bit for bit).
#include <ostream>

#include "cosim/config/config_reader.hpp"
#include "cosim/coupler/config/scene.hpp"
#include "cosim/coupler/couplings/coupling.hpp"
#include "cosim/io/h5_file.hpp"
#include "cosim/wire/arrays.hpp"

namespace cosim::coupler {
namespace {

class DirectTransfer final : public Coupling {
 public:
  DirectTransfer(const std::string& name, config::MapReader& m, const std::vector<SolverSpec>& solvers)
      : Coupling(name) {
    from_ = requireSolverName(m, "from", solvers);
    to_ = requireSolverName(m, "to", solvers);
    const bool given = m.has("arrays");
    arrays_ = m.stringList("arrays");
    if (arrays_.empty()) m.error("arrays", given ? "is empty: name at least one array to transfer"
                                                 : "missing: the names of the arrays to transfer");
    if (!from_.empty() && from_ == to_) m.error("to", "a transfer needs two different solvers");
  }

  std::string kind() const override { return "direct-transfer"; }
  std::vector<std::string> participants() const override { return {from_, to_}; }
  std::vector<std::string> requiredCapabilities(const std::string&) const override { return {"arrays"}; }

  void describe(std::ostream& out) const override {
    out << from_ << " -> " << to_ << ": arrays";
    for (const auto& a : arrays_) out << " " << a;
  }

  void exchange(ExchangeContext& ctx) override {
    auto source = ctx.outputs.find(from_);
    if (source == ctx.outputs.end()) return;
    auto& target = ctx.inputs[to_];
    for (const auto& name : arrays_) {
      proto::NamedArray::Reader array;
      if (!wire::findArray(source->second.getArrays(), name, array))
        throw std::runtime_error("coupling '" + this->name() + "': solver '" + from_ + "' sent no array '" + name +
                                 "' at exchange " + std::to_string(ctx.exchange));
      target.stageArray(name, array.getComponents(), wire::view(array.getValues()));
    }
  }

 private:
  std::string from_;
  std::string to_;
  std::vector<std::string> arrays_;
};

const bool registered = CouplingRegistry::add(
    "direct-transfer", [](const std::string& name, config::MapReader& m, const std::vector<SolverSpec>& solvers) {
      return std::make_unique<DirectTransfer>(name, m, solvers);
    });

}  // namespace
}  // namespace cosim::coupler
