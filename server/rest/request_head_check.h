// The checks of an HTTP/1.1 request's head (its request line and header
// fields) by RFC 9112, made on the raw bytes as they arrive and before
// cpp-httplib parses them: httplib 0.11 reads a line whole however long it is,
// takes any number of header fields, cuts a value at a NUL (so that nothing
// after it is seen), and frames a body by Content-Length when
// Transfer-Encoding is anything but exactly "chunked", which lets a request
// hide a second one in its body (request smuggling). A head that passes
// frames its body one way only.
//
// Thread safety: a RequestHeadCheck belongs to one connection's thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace mm::service::rest {

// What a request head may hold (RestOptions documents the defaults).
struct RequestHeadLimits {
  size_t max_head_bytes = 64 << 10;  // request line and fields with their CRLFs, and the blank line
  size_t max_line_bytes = 8190;      // one line without its CRLF
  size_t max_fields = 200;           // header fields
};

// Where checking a head stands: more bytes needed, a whole head that
// passed, or a refusal with its HTTP status and a message naming what and
// why (never a header's value: it may be a token).
struct HeadVerdict {
  enum class State { kNeedMore, kComplete, kRefused };
  State state = State::kNeedMore;
  size_t head_bytes = 0;  // kComplete: the head's length, blank line included
  int status = 0;         // kRefused: 400, 414, 431 or 501
  std::string message;    // kRefused
  bool chunked = false;   // kComplete: the body is chunked (Transfer-Encoding: chunked)
  std::optional<uint64_t> content_length;  // kComplete: the declared length, if any
  // kComplete: a Content-Length that is not a number: the request is
  // answered (its route refuses it) and the connection closed after it.
  bool close_after = false;
};

// Checks one request's head incrementally: advance() is given the bytes
// received so far from the request's first byte on (the same prefix, grown),
// and looks only at what it has not seen yet, so a head sent a byte at a
// time costs its length once. A line is refused as soon as it is longer than
// the limit, before the rest of it arrives.
class RequestHeadCheck {
 public:
  explicit RequestHeadCheck(RequestHeadLimits limits) : limits_(limits) {}

  // kNeedMore until the blank line that ends the head has arrived; then
  // kComplete or kRefused, which stay the verdict.
  HeadVerdict advance(std::string_view received);

 private:
  HeadVerdict refuse(int status, std::string message);
  // Checks one whole line (without its CRLF); false after refusing it.
  bool check_line(std::string_view line);
  bool check_request_line(std::string_view line);
  bool check_field(std::string_view line);
  HeadVerdict complete(size_t head_bytes);

  RequestHeadLimits limits_;
  HeadVerdict verdict_;
  size_t scanned_ = 0;  // bytes of whole lines checked
  size_t fields_ = 0;
  bool http10_ = false;
  std::optional<uint64_t> content_length_;
  std::string content_length_text_;  // the first Content-Length as sent (digits only once checked)
  std::string transfer_codings_;     // every Transfer-Encoding value, comma-joined, lower case
  bool has_transfer_encoding_ = false;
  bool invalid_length_ = false;
};

}  // namespace mm::service::rest
