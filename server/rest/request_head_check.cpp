#include "server/rest/request_head_check.h"

#include <cstdio>
#include <vector>

namespace mm::service::rest {

namespace {

bool is_control(unsigned char c) { return c < 0x20 || c == 0x7F; }

// RFC 9110 5.6.2: the bytes of a token, which a field name is.
bool is_token_char(unsigned char c) {
  if (c >= '0' && c <= '9') return true;
  if ((c | 0x20) >= 'a' && (c | 0x20) <= 'z') return true;
  switch (c) {
    case '!': case '#': case '$': case '%': case '&': case '\'': case '*': case '+':
    case '-': case '.': case '^': case '_': case '`': case '|': case '~':
      return true;
    default:
      return false;
  }
}

std::string hex_byte(unsigned char c) {
  char text[8];
  std::snprintf(text, sizeof text, "0x%02X", c);
  return text;
}

// A field name or value as a message may quote it: visible ASCII kept, any
// other byte as \xNN, cut at 64 bytes.
std::string quoted(std::string_view text) {
  std::string out;
  for (size_t i = 0; i < text.size() && i < 64; ++i) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7F) {
      out += static_cast<char>(c);
    } else {
      out += "\\x" + hex_byte(c).substr(2);
    }
  }
  if (text.size() > 64) out += "...";
  return "\"" + out + "\"";
}

bool equals_ignoring_case(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if ((a[i] | 0x20) != (b[i] | 0x20)) return false;
  }
  return true;
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t')) text.remove_suffix(1);
  return text;
}

}  // namespace

HeadVerdict RequestHeadCheck::refuse(int status, std::string message) {
  verdict_.state = HeadVerdict::State::kRefused;
  verdict_.status = status;
  verdict_.message = std::move(message);
  return verdict_;
}

HeadVerdict RequestHeadCheck::advance(std::string_view received) {
  while (verdict_.state == HeadVerdict::State::kNeedMore) {
    const size_t newline = received.find('\n', scanned_);
    if (newline == std::string_view::npos) {
      // A line still arriving is refused as soon as it is too long (its CR
      // may be the last byte so far), not once it has arrived whole.
      if (received.size() - scanned_ > limits_.max_line_bytes + 1) {
        const bool request_line = scanned_ == 0;
        return refuse(request_line ? 414 : 431,
                      std::string(request_line ? "the request line" : "a header line") + " is longer than " +
                          std::to_string(limits_.max_line_bytes) + " bytes (--rest-max-line-bytes)");
      }
      if (received.size() > limits_.max_head_bytes) break;
      return verdict_;
    }
    if (newline == scanned_ || received[newline - 1] != '\r') {
      return refuse(400, "a line of the request's head ends with a bare LF; HTTP/1.1 lines end with CRLF "
                         "(RFC 9112 2.2)");
    }
    const size_t next = newline + 1;
    if (next > limits_.max_head_bytes) break;
    const std::string_view line = received.substr(scanned_, newline - 1 - scanned_);
    if (line.empty()) {
      if (scanned_ == 0) return refuse(400, "the request begins with an empty line, expected a request line");
      scanned_ = next;
      return complete(next);
    }
    if (!check_line(line)) return verdict_;
    scanned_ = next;
  }
  if (verdict_.state != HeadVerdict::State::kNeedMore) return verdict_;
  return refuse(431, "the request's head (request line and header fields) is longer than " +
                         std::to_string(limits_.max_head_bytes) + " bytes (--rest-max-header-bytes)");
}

bool RequestHeadCheck::check_line(std::string_view line) {
  const bool request_line = scanned_ == 0;
  if (line.size() > limits_.max_line_bytes) {
    refuse(request_line ? 414 : 431, std::string(request_line ? "the request line" : "a header line") +
                                         " is longer than " + std::to_string(limits_.max_line_bytes) +
                                         " bytes (--rest-max-line-bytes)");
    return false;
  }
  return request_line ? check_request_line(line) : check_field(line);
}

bool RequestHeadCheck::check_request_line(std::string_view line) {
  for (size_t i = 0; i < line.size(); ++i) {
    const auto c = static_cast<unsigned char>(line[i]);
    if (is_control(c)) {
      refuse(400, "the request line has the control character " + hex_byte(c) + " at byte " + std::to_string(i) +
                      "; it takes visible characters and single spaces");
      return false;
    }
  }
  const size_t space = line.rfind(' ');
  http10_ = space != std::string_view::npos && line.substr(space + 1) == "HTTP/1.0";
  return true;
}

bool RequestHeadCheck::check_field(std::string_view line) {
  if (line.front() == ' ' || line.front() == '\t') {
    refuse(400, "a header line begins with whitespace (a folded line), which HTTP/1.1 no longer takes "
                "(RFC 9112 5.2); send each field on one line");
    return false;
  }
  if (++fields_ > limits_.max_fields) {
    refuse(431, "the request has more than " + std::to_string(limits_.max_fields) +
                    " header fields (--rest-max-headers)");
    return false;
  }
  const size_t colon = line.find(':');
  if (colon == std::string_view::npos) {
    refuse(400, "the header line " + quoted(line) + " has no colon, expected name: value");
    return false;
  }
  const std::string_view name = line.substr(0, colon);
  for (const char byte : name) {
    if (!is_token_char(static_cast<unsigned char>(byte))) {
      refuse(400, "the header name " + quoted(name) + " has the byte " + hex_byte(static_cast<unsigned char>(byte)) +
                      ", expected letters, digits and !#$%&'*+-.^_`|~ only, with no space before the colon "
                      "(RFC 9110 5.1)");
      return false;
    }
  }
  if (name.empty()) {
    refuse(400, "a header line begins with a colon, expected name: value");
    return false;
  }
  const std::string_view raw_value = line.substr(colon + 1);
  for (size_t i = 0; i < raw_value.size(); ++i) {
    const auto c = static_cast<unsigned char>(raw_value[i]);
    // The value is never quoted: it may be a token.
    if (is_control(c) && c != '\t') {
      refuse(400, "the header " + quoted(name) + " has the control character " + hex_byte(c) + " at byte " +
                      std::to_string(i) + " of its value; a value takes visible characters, spaces and tabs "
                      "(RFC 9110 5.5)");
      return false;
    }
  }
  const std::string_view value = trim(raw_value);
  if (equals_ignoring_case(name, "Content-Length")) {
    const bool digits = !value.empty() && value.size() <= 18 &&
                        value.find_first_not_of("0123456789") == std::string_view::npos;
    if (!digits) {
      // Answered 400 by the route that reads the body (or 404 by none),
      // naming the value as it always was; the connection then ends, as
      // where the body ends is unknown.
      invalid_length_ = true;
      return true;
    }
    const uint64_t length = std::stoull(std::string(value));
    if (content_length_ && *content_length_ != length) {
      refuse(400, "the request has two Content-Length headers that disagree (" + content_length_text_ + " and " +
                      std::string(value) + "), so its body's length is ambiguous (RFC 9112 6.3); send one");
      return false;
    }
    content_length_ = length;
    content_length_text_ = std::string(value);
  } else if (equals_ignoring_case(name, "Transfer-Encoding")) {
    has_transfer_encoding_ = true;
    if (!transfer_codings_.empty()) transfer_codings_ += ',';
    for (const char byte : value) transfer_codings_ += static_cast<char>(byte >= 'A' && byte <= 'Z' ? byte | 0x20 : byte);
  }
  return true;
}

HeadVerdict RequestHeadCheck::complete(size_t head_bytes) {
  if (has_transfer_encoding_) {
    if (content_length_ || invalid_length_) {
      return refuse(400, "the request has both Transfer-Encoding and Content-Length, which frame its body two ways "
                         "(RFC 9112 6.1); send one");
    }
    if (http10_) return refuse(400, "an HTTP/1.0 request may not have a Transfer-Encoding (RFC 9112 6.1)");
    std::vector<std::string> codings;
    size_t start = 0;
    while (start <= transfer_codings_.size()) {
      size_t comma = transfer_codings_.find(',', start);
      if (comma == std::string::npos) comma = transfer_codings_.size();
      const std::string_view coding = trim(std::string_view(transfer_codings_).substr(start, comma - start));
      if (!coding.empty()) codings.emplace_back(coding);
      start = comma + 1;
    }
    if (codings.empty() || codings.back() != "chunked") {
      return refuse(400, "Transfer-Encoding " + quoted(transfer_codings_) +
                             " does not end in chunked, so the body's length is unknown (RFC 9112 6.3); send a "
                             "chunked body or a Content-Length");
    }
    for (size_t i = 0; i + 1 < codings.size(); ++i) {
      if (codings[i] == "chunked") {
        return refuse(400, "Transfer-Encoding " + quoted(transfer_codings_) +
                               " applies chunked more than once (RFC 9112 7)");
      }
      return refuse(501, "the transfer coding " + quoted(codings[i]) +
                             " is not supported; send the body chunked only");
    }
  }
  verdict_.state = HeadVerdict::State::kComplete;
  verdict_.head_bytes = head_bytes;
  verdict_.chunked = has_transfer_encoding_;
  verdict_.content_length = content_length_;
  verdict_.close_after = invalid_length_;
  return verdict_;
}

}  // namespace mm::service::rest
