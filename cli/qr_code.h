// QR codes for pairing a phone with the scout app (libqrencode): drawn in a
// terminal and written as PNG. A scanner reads both: the terminal form
// sets black and white explicitly (ANSI colours), whatever the terminal's
// own colours, and both keep the 4-module quiet zone the standard asks for.
#pragma once

#include <string>
#include <vector>

namespace arscout::cli {

struct QrCode {
  int size = 0;                 // modules per side, without the quiet zone
  std::vector<bool> dark;       // size * size, row-major
  bool at(int x, int y) const;  // false outside the code (the quiet zone)
};

// The smallest QR code (error correction level M) holding `text` as 8-bit
// bytes. Throws std::runtime_error when it does not fit (over ~2300 bytes).
QrCode encode_qr(const std::string& text);

// Two module rows per text line with upper half blocks, each cell's
// foreground the upper module and background the lower one.
std::string qr_for_terminal(const QrCode& code);

// Black modules on white, `scale` pixels each, quiet zone included.
// Throws std::runtime_error when the file cannot be written.
void write_qr_png(const QrCode& code, const std::string& path, int scale = 8);

}  // namespace arscout::cli
