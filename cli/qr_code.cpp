#include "qr_code.h"

#include <qrencode.h>

#include <memory>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

namespace arscout::cli {
namespace {

constexpr int kQuietZone = 4;  // modules of light margin on each side

}  // namespace

bool QrCode::at(int x, int y) const {
  if (x < 0 || y < 0 || x >= size || y >= size) return false;
  return dark[static_cast<size_t>(y) * size + x];
}

QrCode encode_qr(const std::string& text) {
  std::unique_ptr<QRcode, decltype(&QRcode_free)> raw(
      QRcode_encodeData(static_cast<int>(text.size()),
                        reinterpret_cast<const unsigned char*>(text.data()), 0,
                        QR_ECLEVEL_M),
      &QRcode_free);
  if (!raw) {
    throw std::runtime_error("cannot make a QR code of " +
                             std::to_string(text.size()) +
                             " bytes (too long for a QR code?)");
  }
  QrCode code;
  code.size = raw->width;
  code.dark.resize(static_cast<size_t>(code.size) * code.size);
  // libqrencode: bit 0 of each byte is the module's colour (1 = dark).
  for (size_t i = 0; i < code.dark.size(); ++i) code.dark[i] = raw->data[i] & 1;
  return code;
}

std::string qr_for_terminal(const QrCode& code) {
  const char* kBlack = "0";
  const char* kWhite = "7";
  std::string out;
  const int first = -kQuietZone;
  const int last = code.size + kQuietZone;
  for (int y = first; y < last; y += 2) {
    for (int x = first; x < last; ++x) {
      // Foreground (3x) paints the upper half block, background (4x) the rest.
      out += "\033[3";
      out += code.at(x, y) ? kBlack : kWhite;
      out += ";4";
      out += code.at(x, y + 1) ? kBlack : kWhite;
      out += "m\u2580";
    }
    out += "\033[0m\n";
  }
  return out;
}

void write_qr_png(const QrCode& code, const std::string& path, int scale) {
  const int side = (code.size + 2 * kQuietZone) * scale;
  cv::Mat image(side, side, CV_8U, cv::Scalar(255));
  for (int y = 0; y < code.size; ++y) {
    for (int x = 0; x < code.size; ++x) {
      if (!code.at(x, y)) continue;
      image(cv::Rect((x + kQuietZone) * scale, (y + kQuietZone) * scale, scale,
                     scale))
          .setTo(0);
    }
  }
  if (!cv::imwrite(path, image)) {
    throw std::runtime_error(path + ": cannot write the QR code's PNG");
  }
}

}  // namespace arscout::cli
