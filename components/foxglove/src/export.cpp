#include <ddsnav/foxglove/export.hpp>
#include <ddsnav/foxglove/schemas.hpp>

namespace ddsnav::foxglove {

std::uint16_t addDerivedChannel(record::McapWriter& out, const DerivedChannel& channel) {
  const std::uint16_t schema = out.addSchema(channel.schema_name, std::string(kSchemaEncoding),
                                             jsonSchema(channel.schema_name).dump());
  return out.addChannel(schema, channel.topic, std::string(kMessageEncoding), {{"derived", "foxglove"}});
}

ExportStats exportFoxglove(const record::McapReader& in, record::McapWriter& out, SceneDeriverOptions options,
                           SceneSvg* picture) {
  ExportStats stats;
  SceneDeriver derive(std::move(options));
  std::map<std::uint16_t, std::uint16_t> copied_channel;  // input channel id -> output channel id
  std::map<std::uint16_t, std::uint16_t> copied_schema;
  std::map<std::string, std::uint16_t> derived_channel;   // derived topic -> output channel id (schemas once per name)
  std::map<std::string, std::uint16_t> derived_schema;

  auto derivedChannel = [&](const DerivedChannel& c) {
    if (auto it = derived_channel.find(c.topic); it != derived_channel.end()) return it->second;
    auto schema = derived_schema.find(c.schema_name);
    if (schema == derived_schema.end())
      schema = derived_schema.emplace(c.schema_name, out.addSchema(c.schema_name, std::string(kSchemaEncoding),
                                                                   jsonSchema(c.schema_name).dump())).first;
    const auto id = out.addChannel(schema->second, c.topic, std::string(kMessageEncoding), {{"derived", "foxglove"}});
    derived_channel.emplace(c.topic, id);
    return id;
  };
  auto writeDerived = [&](const std::vector<DerivedMessage>& messages, std::uint64_t log_time) {
    for (const auto& m : messages) {
      const auto* bytes = reinterpret_cast<const std::uint8_t*>(m.json.data());
      out.write(derivedChannel(m.channel), log_time, static_cast<std::uint64_t>(m.stamp_ns), {bytes, m.json.size()});
      ++stats.derived[m.channel.topic];
      if (picture && m.channel.schema_name == "foxglove.SceneUpdate") picture->add(m.channel.topic, nlohmann::json::parse(m.json));
    }
  };

  bool first = true;
  in.forEachMessage([&](const record::MessageView& m) {
    const record::Channel& channel = *m.channel;
    const record::Schema* schema = nullptr;
    if (auto s = in.schemas().find(channel.schema_id); s != in.schemas().end()) schema = &s->second;
    auto it = copied_channel.find(channel.id);
    if (it == copied_channel.end()) {
      std::uint16_t schema_id = 0;  // 0: a channel without schema stays so
      if (schema) {
        auto cs = copied_schema.find(schema->id);
        if (cs == copied_schema.end()) cs = copied_schema.emplace(schema->id, out.addSchema(schema->name, schema->encoding, schema->data)).first;
        schema_id = cs->second;
      }
      it = copied_channel.emplace(channel.id, out.addChannel(schema_id, channel.topic, channel.message_encoding, channel.metadata)).first;
    }
    if (first) {  // the scenario scene at the recording's start
      first = false;
      writeDerived(derive.standingMessages(static_cast<std::int64_t>(m.log_time)), m.log_time);
    }
    out.write(it->second, m.log_time, m.publish_time, m.data);
    ++stats.copied;
    // ddsnav recordings: omgidl schema named by the DDS type, cdr payloads.
    if (schema && channel.message_encoding == "cdr" && !SceneDeriver::channelsFor(channel.topic, schema->name).empty()) {
      try {
        writeDerived(derive.onSample(channel.topic, schema->name, m.data), m.log_time);
      } catch (const ConversionError& e) {
        ++stats.failed;
        if (stats.first_errors.size() < 5) stats.first_errors.push_back(e.what());
      }
    }
    return true;
  });
  for (const auto& md : in.metadata()) out.addMetadata(md.name, md.values);
  return stats;
}

}  // namespace ddsnav::foxglove
