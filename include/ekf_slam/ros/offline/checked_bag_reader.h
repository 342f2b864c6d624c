// Reads bag messages with every length field checked before anything is allocated.
//
// rosbag's deserialiser resizes an array to whatever length it reads and only then finds that
// the bytes are missing: one corrupted length field in a LaserScan made the offline runner
// allocate gigabytes (issue 15). Here the message's serialized bytes (MessageInstance::size(),
// at most kMaxMessageBytes) are first walked along the layout of the connection's own message
// definition (the text every bag stores per connection), so each string and array length is
// compared with the bytes left, and the fields must use up the message exactly. Only then is the
// message deserialised, from that buffer.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <ros/serialization.h>
#include <rosbag/message_instance.h>
#include <boost/shared_ptr.hpp>

namespace ekf_slam {

/// A message whose bytes do not fit its definition (what() says which field and why).
class CorruptMessageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Checks the record structure of a bag file (format 2.0) before rosbag opens it: rosbag trusts
/// every length and offset in the file (a corrupted record header made it allocate whatever
/// size it read, then assert). Walks every record: header and data lengths within the file,
/// header fields well formed, chunk sizes at most kMaxChunkBytes, index offsets within their
/// chunk, and the records inside uncompressed chunks likewise (compressed chunks are left to
/// rosbag's decompressor; bags of the old format 1.2 are left to rosbag). Streams the file:
/// memory is one chunk. Throws CorruptMessageError
/// naming the byte offset and the record.
void checkBagStructure(const std::string& path);
constexpr std::uint32_t kMaxChunkBytes = 256u << 20;

/// The layout of one message type, parsed from a bag connection's message definition.
class MessageLayout {
 public:
  /// Parses `definition` (gendeps --cat format: the type's fields, then "MSG: pkg/Type"
  /// sections). Throws CorruptMessageError when a field type cannot be resolved.
  MessageLayout(const std::string& datatype, const std::string& definition);
  /// Throws CorruptMessageError unless `bytes` are exactly one message of this type with every
  /// length field within the bytes. O(bytes).
  void check(const std::uint8_t* bytes, std::size_t size) const;

 private:
  struct Field {
    std::string name;
    std::size_t primitive = 0;  // bytes of a primitive; 0 for string or message
    bool string = false;
    int message = -1;  // index into types_ for a nested message
    bool array = false;
    std::uint32_t count = 0;  // fixed array length; 0 with array: variable length
  };
  struct Type {
    std::string name;
    std::vector<Field> fields;
  };
  const std::uint8_t* walk(int type, const std::uint8_t* p, const std::uint8_t* end,
                           const std::string& path) const;
  std::size_t minimumSize(int type) const;
  std::vector<Type> types_;  // types_[0] is the message itself
};

/// Deserialises bag messages through MessageLayout checks (one parsed layout per connection).
class CheckedBagReader {
 public:
  /// A serialized message larger than this is refused (a 10^5-beam LaserScan is 0.8 MB).
  static constexpr std::uint32_t kMaxMessageBytes = 64u << 20;

  /// The message as T; null when it is not a T (another md5sum). Throws CorruptMessageError.
  template <class T>
  boost::shared_ptr<T> instantiate(const rosbag::MessageInstance& m) {
    if (!m.isType<T>()) return nullptr;
    const std::vector<std::uint8_t>& bytes = read(m);
    auto msg = boost::make_shared<T>();
    ros::serialization::IStream in(const_cast<std::uint8_t*>(bytes.data()),
                                   static_cast<std::uint32_t>(bytes.size()));
    ros::serialization::deserialize(in, *msg);
    return msg;
  }

 private:
  /// The message's bytes, checked against its connection's layout.
  const std::vector<std::uint8_t>& read(const rosbag::MessageInstance& m);

  std::map<std::string, std::unique_ptr<MessageLayout>> layouts_;  // by md5sum + definition
  std::vector<std::uint8_t> buffer_;
};

}  // namespace ekf_slam
