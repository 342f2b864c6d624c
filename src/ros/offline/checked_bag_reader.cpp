#include "ekf_slam/ros/offline/checked_bag_reader.h"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <limits>
#include <sstream>

namespace ekf_slam {

namespace {

// Serialized size of a ROS built-in type; 0 when `type` is not a fixed-size built-in.
std::size_t primitiveSize(const std::string& type) {
  static const std::map<std::string, std::size_t> sizes = {
      {"bool", 1},  {"int8", 1},   {"uint8", 1},   {"byte", 1},   {"char", 1},
      {"int16", 2}, {"uint16", 2}, {"int32", 4},   {"uint32", 4}, {"float32", 4},
      {"int64", 8}, {"uint64", 8}, {"float64", 8}, {"time", 8},   {"duration", 8}};
  const auto it = sizes.find(type);
  return it == sizes.end() ? 0 : it->second;
}

std::string trim(const std::string& s) {
  const std::size_t b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

std::string packageOf(const std::string& datatype) {
  const std::size_t slash = datatype.find('/');
  return slash == std::string::npos ? "" : datatype.substr(0, slash);
}

// A uint32 length at *p that must fit in the bytes after it (up to `end`); advances p past it.
std::uint32_t boundedLength(const std::uint8_t*& p, const std::uint8_t* end,
                            const std::string& where, const char* what, const char* within) {
  if (end - p < 4) throw CorruptMessageError(where + ": truncated " + what);
  std::uint32_t len;
  std::memcpy(&len, p, 4);
  p += 4;
  if (static_cast<std::uint64_t>(end - p) < len)
    throw CorruptMessageError(where + ": " + what + " of " + std::to_string(len) +
                              " bytes overruns its " + within);
  return len;
}

// One record header's fields (name -> value), parsed with every length checked.
std::map<std::string, std::string> parseHeader(const std::uint8_t* p, std::size_t size,
                                               const std::string& where) {
  std::map<std::string, std::string> fields;
  const std::uint8_t* end = p + size;
  while (p < end) {
    const std::uint32_t len = boundedLength(p, end, where, "header field", "header");
    const std::string field(reinterpret_cast<const char*>(p), len);
    p += len;
    const std::size_t eq = field.find('=');
    if (eq == std::string::npos) throw CorruptMessageError(where + ": header field without '='");
    fields[field.substr(0, eq)] = field.substr(eq + 1);
  }
  return fields;
}

template <class T>
T fieldValue(const std::map<std::string, std::string>& h, const std::string& name,
             const std::string& where) {
  const auto it = h.find(name);
  if (it == h.end() || it->second.size() != sizeof(T))
    throw CorruptMessageError(where + ": header field '" + name + "' missing or malformed");
  T v;
  std::memcpy(&v, it->second.data(), sizeof(T));
  return v;
}

// Records of the bag format 2.0 (op codes).
enum Op : std::uint8_t {
  kMessageData = 2,
  kBagHeader = 3,
  kIndexData = 4,
  kChunk = 5,
  kChunkInfo = 6,
  kConnection = 7
};
// Longest record header accepted (connection headers carry message definitions, a few kB).
constexpr std::uint32_t kMaxHeaderBytes = 16u << 20;

// Walks the records in [p, end) (inside an uncompressed chunk: message data and connections).
void checkChunkRecords(const std::uint8_t* p, const std::uint8_t* end, std::uint64_t base) {
  const std::uint8_t* begin = p;
  while (p < end) {
    const std::string where = "record at byte " + std::to_string(base + (p - begin));
    const std::uint32_t len = boundedLength(p, end, where, "header", "chunk");
    const auto h = parseHeader(p, len, where);
    p += len;
    const auto op = fieldValue<std::uint8_t>(h, "op", where);
    if (op != kMessageData && op != kConnection)
      throw CorruptMessageError(where + ": unexpected record type " + std::to_string(op));
    const std::uint32_t data = boundedLength(p, end, where, "data", "chunk");
    p += data;
  }
}

}  // namespace

void checkBagStructure(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw CorruptMessageError("cannot read " + path);
  in.seekg(0, std::ios::end);
  const std::uint64_t file_size = static_cast<std::uint64_t>(in.tellg());
  in.seekg(0);
  const std::string magic = "#ROSBAG V2.0\n";
  std::string head(magic.size(), '\0');
  if (!in.read(&head[0], head.size()) || head.compare(0, 9, "#ROSBAG V") != 0)
    throw CorruptMessageError("not a rosbag (no '#ROSBAG V' at its start)");
  if (head != magic) return;  // an older format (1.2): left to rosbag
  std::uint64_t pos = magic.size();
  std::vector<std::uint8_t> buf;
  std::uint64_t chunk_size = 0;  // uncompressed size of the last chunk
  const auto read = [&](std::uint64_t n, const std::string& where) {
    buf.resize(n);
    if (n > 0 && !in.read(reinterpret_cast<char*>(buf.data()), static_cast<std::streamsize>(n)))
      throw CorruptMessageError(where + ": unexpected end of file");
    pos += n;
  };
  const auto length = [&](const std::string& where, const char* what, std::uint64_t limit) {
    read(4, where);
    std::uint32_t len;
    std::memcpy(&len, buf.data(), 4);
    if (len > file_size - pos || len > limit)
      throw CorruptMessageError(where + ": " + what + " of " + std::to_string(len) + " bytes (" +
                                std::to_string(file_size - pos) + " left in the file)");
    return len;
  };
  while (pos < file_size) {
    const std::string where = "record at byte " + std::to_string(pos);
    read(length(where, "header", kMaxHeaderBytes), where);
    const auto h = parseHeader(buf.data(), buf.size(), where);
    const auto op = fieldValue<std::uint8_t>(h, "op", where);
    const std::uint32_t data_len = length(where, "data", std::numeric_limits<std::uint32_t>::max());
    switch (op) {
      case kBagHeader:
        if (fieldValue<std::uint64_t>(h, "index_pos", where) > file_size)
          throw CorruptMessageError(where + ": index position beyond the end of the file");
        break;
      case kChunk: {
        chunk_size = fieldValue<std::uint32_t>(h, "size", where);
        const auto c = h.find("compression");
        if (chunk_size > kMaxChunkBytes || c == h.end())
          throw CorruptMessageError(where + ": chunk of " + std::to_string(chunk_size) +
                                    " bytes (at most " + std::to_string(kMaxChunkBytes) + ")");
        if (c->second == "none") {
          if (chunk_size != data_len)
            throw CorruptMessageError(where + ": uncompressed chunk size differs from its data");
          read(data_len, where);
          checkChunkRecords(buf.data(), buf.data() + buf.size(), pos - data_len);
          continue;
        }
        break;
      }
      case kIndexData: {
        const auto count = fieldValue<std::uint32_t>(h, "count", where);
        if (static_cast<std::uint64_t>(count) * 12 != data_len)
          throw CorruptMessageError(where + ": index count disagrees with its data");
        read(data_len, where);
        for (std::uint32_t i = 0; i < count; ++i) {
          std::uint32_t offset;
          std::memcpy(&offset, buf.data() + 12 * i + 8, 4);
          if (offset >= chunk_size)
            throw CorruptMessageError(where + ": index entry beyond its chunk");
        }
        continue;
      }
      case kChunkInfo:
        if (fieldValue<std::uint64_t>(h, "chunk_pos", where) >= file_size ||
            static_cast<std::uint64_t>(fieldValue<std::uint32_t>(h, "count", where)) * 8 !=
                data_len)
          throw CorruptMessageError(where + ": chunk info out of the file or inconsistent");
        break;
      case kConnection:
      case kMessageData:
        break;
      default:
        throw CorruptMessageError(where + ": unknown record type " + std::to_string(op));
    }
    in.seekg(static_cast<std::streamoff>(pos + data_len));
    pos += data_len;
  }
}

MessageLayout::MessageLayout(const std::string& datatype, const std::string& definition) {
  // Sections: the message's own fields, then "MSG: pkg/Type" blocks separated by "====" lines.
  struct Section {
    std::string name;
    std::vector<std::string> lines;
  };
  std::vector<Section> sections{{datatype, {}}};
  std::istringstream in(definition);
  for (std::string line; std::getline(in, line);) {
    line = trim(line.substr(0, line.find('#')));  // a comment may contain '='
    if (line.empty() || line.compare(0, 3, "===") == 0) continue;
    if (line.compare(0, 4, "MSG:") == 0) {
      sections.push_back({trim(line.substr(4)), {}});
      continue;
    }
    if (line.find('=') != std::string::npos) continue;  // a constant
    sections.back().lines.push_back(line);
  }
  types_.resize(sections.size());
  for (std::size_t s = 0; s < sections.size(); ++s) types_[s].name = sections[s].name;
  const auto resolve = [&](std::string base, const std::string& owner) {
    if (base == "Header") base = "std_msgs/Header";
    if (base.find('/') == std::string::npos) base = packageOf(owner) + "/" + base;
    for (std::size_t s = 0; s < types_.size(); ++s) {
      if (types_[s].name == base) return static_cast<int>(s);
    }
    // Some writers qualify nested names differently: match the bare type name.
    const std::string bare = base.substr(base.find('/') + 1);
    for (std::size_t s = 0; s < types_.size(); ++s) {
      const std::string& n = types_[s].name;
      if (n.size() > bare.size() &&
          n.compare(n.size() - bare.size() - 1, std::string::npos, "/" + bare) == 0)
        return static_cast<int>(s);
    }
    throw CorruptMessageError("message definition of " + datatype + ": unknown type " + base);
  };
  for (std::size_t s = 0; s < sections.size(); ++s) {
    for (const std::string& line : sections[s].lines) {
      std::istringstream fields(line);
      std::string type, name;
      fields >> type >> name;
      Field f;
      f.name = name;
      const std::size_t bracket = type.find('[');
      if (bracket != std::string::npos) {
        f.array = true;
        const std::string n = type.substr(bracket + 1, type.find(']') - bracket - 1);
        f.count = n.empty() ? 0 : static_cast<std::uint32_t>(std::stoul(n));
        type = type.substr(0, bracket);
      }
      f.primitive = primitiveSize(type);
      f.string = type == "string";
      if (f.primitive == 0 && !f.string) f.message = resolve(type, sections[s].name);
      types_[s].fields.push_back(f);
    }
  }
}

std::size_t MessageLayout::minimumSize(int type) const {
  std::size_t size = 0;
  for (const Field& f : types_[type].fields) {
    if (f.array && f.count == 0) {
      size += 4;  // the length
      continue;
    }
    const std::size_t one = f.primitive ? f.primitive : f.string ? 4 : minimumSize(f.message);
    size += (f.array ? f.count : 1) * one;
  }
  return size;
}

const std::uint8_t* MessageLayout::walk(int type, const std::uint8_t* p, const std::uint8_t* end,
                                        const std::string& path) const {
  const auto length = [&](const std::string& field) {
    if (end - p < 4) throw CorruptMessageError(field + ": message ends before its length");
    std::uint32_t n;
    std::memcpy(&n, p, 4);
    p += 4;
    return n;
  };
  for (const Field& f : types_[type].fields) {
    const std::string field = path.empty() ? f.name : path + "." + f.name;
    std::uint64_t n = f.array ? (f.count ? f.count : length(field)) : 1;
    if (f.primitive || f.string) {
      if (f.primitive) {
        const std::uint64_t bytes = n * f.primitive;
        if (static_cast<std::uint64_t>(end - p) < bytes) {
          throw CorruptMessageError(field + ": " + std::to_string(n) + " elements need " +
                                    std::to_string(bytes) + " bytes, " + std::to_string(end - p) +
                                    " left");
        }
        p += bytes;
        continue;
      }
      for (std::uint64_t i = 0; i < n; ++i) {
        const std::uint32_t len = length(field);
        if (static_cast<std::uint64_t>(end - p) < len) {
          throw CorruptMessageError(field + ": string of " + std::to_string(len) + " bytes, " +
                                    std::to_string(end - p) + " left");
        }
        p += len;
      }
      continue;
    }
    // Nested messages: each needs at least its fixed part, so a corrupted length is caught
    // before the loop (and the loop is bounded by the bytes).
    const std::uint64_t least = std::max<std::size_t>(1, minimumSize(f.message));
    if (f.array && static_cast<std::uint64_t>(end - p) < n * least) {
      throw CorruptMessageError(field + ": " + std::to_string(n) + " elements need at least " +
                                std::to_string(n * least) + " bytes, " + std::to_string(end - p) +
                                " left");
    }
    for (std::uint64_t i = 0; i < n; ++i) p = walk(f.message, p, end, field);
  }
  return p;
}

void MessageLayout::check(const std::uint8_t* bytes, std::size_t size) const {
  const std::uint8_t* end = walk(0, bytes, bytes + size, "");
  if (end != bytes + size) {
    throw CorruptMessageError("the fields of " + types_[0].name + " take " +
                              std::to_string(end - bytes) + " of its " + std::to_string(size) +
                              " bytes");
  }
}

const std::vector<std::uint8_t>& CheckedBagReader::read(const rosbag::MessageInstance& m) {
  const std::uint32_t size = m.size();
  if (size > kMaxMessageBytes) {
    throw CorruptMessageError("serialized size " + std::to_string(size) + " bytes exceeds " +
                              std::to_string(kMaxMessageBytes) + " (corrupted length?)");
  }
  const std::string key = m.getMD5Sum() + m.getMessageDefinition();
  auto it = layouts_.find(key);
  if (it == layouts_.end()) {
    it = layouts_
             .emplace(key,
                      std::make_unique<MessageLayout>(m.getDataType(), m.getMessageDefinition()))
             .first;
  }
  buffer_.resize(size);
  ros::serialization::OStream out(buffer_.data(), size);
  m.write(out);
  it->second->check(buffer_.data(), buffer_.size());
  return buffer_;
}

}  // namespace ekf_slam
