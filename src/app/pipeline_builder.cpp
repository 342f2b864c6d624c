#include "ekf_slam/app/pipeline_builder.h"

#include <map>
#include <memory>
#include <utility>

#include "ekf_slam/core/common/recording_parameter_source.h"
#include "ekf_slam/core/pipeline/pipeline_config.h"

namespace ekf_slam {

std::string pluginLookupName(const std::string& name) {
  return name.find('/') == std::string::npos ? "ekf_slam/" + name : name;
}

std::string pluginShortName(const std::string& name) { return name.substr(name.rfind('/') + 1); }

std::string defaultRelocaliserFor(const std::string& associator) {
  // RRWSC's graph matching recognises landmarks without the pose; its relocaliser is the same
  // matcher, and lost rule 3 (only RRWSC reports gate_refused) is confirmed by it.
  if (pluginLookupName(associator) == "ekf_slam/RRWSC") return "ekf_slam/RRWSC";
  return kDefaultRelocaliser;
}

namespace {

// The rule of relocaliserName on the top-level parameters.
std::string relocaliserIn(const ParameterSource& top, const std::string& associator) {
  std::string name;
  if (!top.get("relocaliser", &name)) name = defaultRelocaliserFor(associator);
  return name.empty() ? "" : pluginLookupName(name);
}

}  // namespace

std::string relocaliserName(const Configuration& configuration) {
  const ParameterSection top = configuration.top();
  std::string associator = kDefaultAssociator;
  top.source->get("associator", &associator);
  return relocaliserIn(*top.source, associator);
}

namespace {

// Parameters whose reads are recorded.
struct RecordedSection {
  explicit RecordedSection(ParameterSection s)
      : section(std::move(s)), source(*section.source, section.names) {}
  ParameterSection section;
  RecordingParameterSource source;
};

// The plugins' sections, one per name: plugins that share a name (the RRWSC associator and
// relocaliser) share its section, and a key either of them reads is known.
class Sections {
 public:
  explicit Sections(const Configuration& c) : configuration_(c) {}
  const RecordingParameterSource& of(const std::string& lookup) {
    auto& s = sections_[pluginShortName(lookup)];
    if (!s) s = std::make_unique<RecordedSection>(configuration_.section(pluginShortName(lookup)));
    return s->source;
  }
  void rejectUnread() const {
    for (const auto& [name, s] : sections_) s->source.rejectUnread();
  }

 private:
  const Configuration& configuration_;
  std::map<std::string, std::unique_ptr<RecordedSection>> sections_;
};

}  // namespace

PipelineParts buildPipeline(const Configuration& configuration, const PluginFactory& plugins) {
  PipelineParts parts;
  const RecordedSection top(configuration.top());
  parts.node = readNodeConfig(top.source);
  parts.config = readPipelineConfig(top.source);
  parts.associator_name =
      pluginLookupName(ParameterReader(top.source).text("associator", kDefaultAssociator));
  parts.extractor_name = pluginLookupName(parts.config.feature_extractor);
  // Set (also to "": off), or the associator's own (defaultRelocaliserFor).
  parts.relocaliser_name = relocaliserIn(top.source, parts.associator_name);
  parts.config.relocaliser = parts.relocaliser_name;

  Sections sections(configuration);
  parts.associator = plugins.associator(parts.associator_name);
  parts.associator->configure(sections.of(parts.associator_name));
  parts.extractor = plugins.extractor(parts.extractor_name);
  if (parts.extractor_name == kDefaultExtractor) {
    // Its historical top-level names (extractor_max_range, ...) keep working.
    parts.extractor->configure(
        FallbackParameterSource(sections.of(parts.extractor_name), top.source, "extractor_"));
  } else {
    parts.extractor->configure(sections.of(parts.extractor_name));
  }
  parts.scan_filter = ScanFilterChain::fromSpecs(configuration.scanFilterChain());
  if (!parts.relocaliser_name.empty()) {
    parts.relocaliser = plugins.relocaliser(parts.relocaliser_name);
    parts.relocaliser->configure(sections.of(parts.relocaliser_name));
  }

  top.source.rejectUnread({"scan_filter_chain"});
  sections.rejectUnread();
  return parts;
}

std::unique_ptr<SlamPipeline> makePipeline(const PipelineParts& parts) {
  auto pipeline = std::make_unique<SlamPipeline>(parts.config, parts.associator);
  pipeline->setFeatureExtractor(parts.extractor);
  pipeline->setScanFilter(parts.scan_filter);
  if (parts.relocaliser) pipeline->setRelocaliser(parts.relocaliser);
  return pipeline;
}

}  // namespace ekf_slam
