// SPDX-License-Identifier: Apache-2.0
#include "devices/falcon_firmware.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iterator>

#include "devices/ftdi_protocol.hpp"

namespace hapticd::falcon {

namespace {

struct StepError {
    FirmwareStage stage;
    TransportStatus status;
    std::string what;
};

std::string hex(unsigned value) {
    static constexpr char kDigits[] = "0123456789ABCDEF";
    std::string out = "0x";
    bool started = false;
    for (int shift = 12; shift >= 0; shift -= 4) {
        const unsigned d = (value >> shift) & 0xF;
        if (d != 0 || started || shift <= 4) {
            out += kDigits[d];
            started = true;
        }
    }
    return out;
}

std::string_view status_text(TransportStatus s) {
    switch (s) {
        case TransportStatus::Ok:
            return "ok";
        case TransportStatus::Timeout:
            return "timeout";
        case TransportStatus::Disconnected:
            return "device disconnected";
        case TransportStatus::AccessDenied:
            return "access denied";
        case TransportStatus::NotFound:
            return "device not found";
        case TransportStatus::Error:
            return "transfer error";
    }
    return "?";
}

// Reads exactly `n` payload bytes (several transfers if needed) or fails. Empty reads (status-only FTDI
// packets) are waited through as libnifalcon's loadFirmware() does; only a lack of progress for
// `echo_patience_ms` (or that many empty reads in a row) is a timeout.
TransportStatus read_exact(FtdiTransport& t, std::uint8_t* out, std::size_t n, const FirmwareUploadConfig& cfg) {
    using Clock = std::chrono::steady_clock;
    std::size_t got = 0;
    int empty_in_a_row = 0;
    Clock::time_point last_progress = Clock::now();
    while (got < n) {
        const TransportResult r = t.read(std::span<std::uint8_t>(out + got, n - got), cfg.timeout_ms);
        if (r.status != TransportStatus::Ok && r.status != TransportStatus::Timeout) return r.status;
        if (r.bytes > 0) {
            got += r.bytes;
            empty_in_a_row = 0;
            last_progress = Clock::now();
            continue;
        }
        const auto waited = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - last_progress);
        if (++empty_in_a_row > cfg.max_consecutive_empty_reads || waited.count() > cfg.echo_patience_ms) {
            return TransportStatus::Timeout;
        }
    }
    return TransportStatus::Ok;
}

bool configure(FtdiTransport& t, StepError& err) {
    using namespace ftdi;
    const std::array<std::pair<std::uint8_t, std::uint16_t>, 11> steps{{
        {kRequestReset, kResetSio},
        {kRequestReset, kPurgeRx},
        {kRequestReset, kPurgeTx},
        {kRequestLatency, kLatencyFirmware},
        {kRequestBaudRate, kBaud9600},
        {kRequestData, kData8N1},
        {kRequestFlowCtrl, 0},
        {kRequestModemCtrl, modem_rts(false)},
        {kRequestModemCtrl, modem_dtr(false)},
        {kRequestModemCtrl, modem_dtr(true)},
        {kRequestReset, kPurgeRx},
    }};
    for (const auto& [request, value] : steps) {
        const TransportStatus s = t.control(request, value, kIndex);
        if (s != TransportStatus::Ok) {
            err = {FirmwareStage::Configure, s,
                   "FTDI control request " + std::to_string(request) + " (value " + hex(value) +
                       ") failed: " + t.last_error()};
            return false;
        }
    }
    return true;
}

bool handshake(FtdiTransport& t, const FirmwareUploadConfig& cfg, StepError& err) {
    static constexpr std::array<std::uint8_t, 3> kQuery{0x0A, 0x43, 0x0D};
    static constexpr std::array<std::uint8_t, 4> kAnswer{0x0A, 0x44, 0x2C, 0x0D};
    using Clock = std::chrono::steady_clock;
    const Clock::time_point start = Clock::now();
    TransportStatus last = TransportStatus::Timeout;
    int tries = 0;
    int empty = 0;  // reads with nothing but the FTDI status bytes (the loader is silent)
    int wrong = 0;  // reads with bytes that are not the answer
    for (; tries < cfg.handshake_tries; ++tries) {
        const TransportResult w = t.write(kQuery, cfg.timeout_ms);
        if (w.status != TransportStatus::Ok) {
            last = w.status;
            if (w.status == TransportStatus::Disconnected) break;
            continue;
        }
        std::array<std::uint8_t, 8> in{};
        const TransportResult r = t.read(in, cfg.timeout_ms);
        last = r.status;
        if (r.status == TransportStatus::Disconnected) break;
        const bool plain = r.bytes == 4 && std::equal(kAnswer.begin(), kAnswer.end(), in.begin());
        const bool with_zero =
            r.bytes == 5 && in[0] == 0x00 && std::equal(kAnswer.begin(), kAnswer.end(), in.begin() + 1);
        if (plain || with_zero) return true;
        ++(r.bytes == 0 ? empty : wrong);
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    char took[32];
    std::snprintf(took, sizeof took, "%.2f s", seconds);
    err = {
        FirmwareStage::Handshake, last == TransportStatus::Ok ? TransportStatus::Error : last,
        "the Falcon's loader did not answer the handshake: " + std::to_string(tries) + " of " +
            std::to_string(cfg.handshake_tries) + " tries in " + took + ", " + std::to_string(empty) +
            " read(s) with no answer, " + std::to_string(wrong) + " with a wrong one" +
            (last == TransportStatus::Ok ? std::string() : " (last transfer: " + std::string(status_text(last)) + ")")};
    return false;
}

bool sync(FtdiTransport& t, const FirmwareUploadConfig& cfg, StepError& err) {
    using namespace ftdi;
    for (const auto& [request, value] :
         {std::pair{kRequestModemCtrl, modem_dtr(false)}, std::pair{kRequestBaudRate, kBaudBootloader}}) {
        const TransportStatus s = t.control(request, value, kIndex);
        if (s != TransportStatus::Ok) {
            err = {FirmwareStage::Sync, s, "FTDI control request failed: " + t.last_error()};
            return false;
        }
    }
    static constexpr std::array<std::uint8_t, 1> kSync{0x41};
    const TransportResult w = t.write(kSync, cfg.timeout_ms);
    std::array<std::uint8_t, 1> echo{};
    const TransportStatus r = w.status == TransportStatus::Ok ? read_exact(t, echo.data(), 1, cfg) : w.status;
    if (r != TransportStatus::Ok || echo[0] != 0x41) {
        err = {FirmwareStage::Sync, r == TransportStatus::Ok ? TransportStatus::Error : r,
               r == TransportStatus::Ok ? "loader answered " + hex(echo[0]) + " instead of 'A'"
                                        : "no answer to 'A': " + std::string(status_text(r))};
        return false;
    }
    return true;
}

bool upload(FtdiTransport& t, std::span<const std::uint8_t> image, const FirmwareUploadConfig& cfg,
            std::size_t& confirmed, StepError& err) {
    std::vector<std::uint8_t> echo(cfg.chunk_size);
    confirmed = 0;
    while (confirmed < image.size()) {
        const std::size_t n = std::min(cfg.chunk_size, image.size() - confirmed);
        const auto chunk = image.subspan(confirmed, n);
        const TransportResult w = t.write(chunk, cfg.timeout_ms);
        if (w.status != TransportStatus::Ok || w.bytes != n) {
            err = {FirmwareStage::Upload, w.status == TransportStatus::Ok ? TransportStatus::Error : w.status,
                   "writing firmware bytes " + std::to_string(confirmed) + ".." + std::to_string(confirmed + n) +
                       " failed: " + std::string(status_text(w.status))};
            return false;
        }
        const TransportStatus r = read_exact(t, echo.data(), n, cfg);
        if (r != TransportStatus::Ok) {
            err = {FirmwareStage::Upload, r,
                   "no echo for firmware bytes " + std::to_string(confirmed) + ".." + std::to_string(confirmed + n) +
                       ": " + std::string(status_text(r))};
            return false;
        }
        for (std::size_t i = 0; i < n; ++i) {
            if (echo[i] != chunk[i]) {
                err = {FirmwareStage::Upload, TransportStatus::Error,
                       "echo mismatch at firmware byte " + std::to_string(confirmed + i) + " (sent " + hex(chunk[i]) +
                           ", got " + hex(echo[i]) + ")"};
                return false;
            }
        }
        confirmed += n;
    }
    return true;
}

}  // namespace

std::string_view to_string(FirmwareStage stage) noexcept {
    switch (stage) {
        case FirmwareStage::Configure:
            return "configure";
        case FirmwareStage::Handshake:
            return "handshake";
        case FirmwareStage::Sync:
            return "sync";
        case FirmwareStage::Upload:
            return "upload";
        case FirmwareStage::NormalMode:
            return "normal mode";
        case FirmwareStage::Done:
            return "done";
    }
    return "?";
}

TransportStatus set_normal_mode(FtdiTransport& t) noexcept {
    using namespace ftdi;
    TransportStatus s = t.control(kRequestLatency, kLatencyNormal, kIndex);
    if (s == TransportStatus::Ok) s = t.control(kRequestBaudRate, kBaudNormal, kIndex);
    if (s == TransportStatus::Ok) s = purge(t);
    return s;
}

FirmwareUploadResult upload_firmware(FtdiTransport& transport, std::span<const std::uint8_t> image,
                                     const FirmwareUploadConfig& cfg, const ReopenTransport& reopen) {
    FirmwareUploadResult result;
    if (image.empty() || cfg.chunk_size == 0 || cfg.attempts < 1) {
        result.message = image.empty() ? "the firmware image is empty" : "invalid firmware upload settings";
        return result;
    }
    FtdiTransport* t = &transport;
    StepError err{FirmwareStage::Configure, TransportStatus::Ok, ""};
    for (int attempt = 1; attempt <= cfg.attempts; ++attempt) {
        result.attempts_used = attempt;
        result.bytes_confirmed = 0;
        if (attempt > 1 && reopen) {
            // Close and reopen between attempts (FalconCLIBase.cpp retries loadFirmware() 10 times; the
            // reopen clears a confused FTDI state that a purge alone does not).
            std::string reopen_error;
            t = reopen(reopen_error);
            if (t == nullptr) {
                err = {FirmwareStage::Configure, TransportStatus::Disconnected,
                       "reopening the Falcon failed: " + reopen_error};
                break;
            }
        }
        const bool ok = configure(*t, err) && handshake(*t, cfg, err) && sync(*t, cfg, err) &&
                        upload(*t, image, cfg, result.bytes_confirmed, err);
        if (ok) {
            const TransportStatus s = set_normal_mode(*t);
            if (s == TransportStatus::Ok) {
                result.ok = true;
                result.stage = FirmwareStage::Done;
                result.message = "firmware uploaded (" + std::to_string(image.size()) + " bytes, attempt " +
                                 std::to_string(attempt) + ")";
                return result;
            }
            err = {FirmwareStage::NormalMode, s, "switching to normal mode failed: " + t->last_error()};
        }
        if (err.status == TransportStatus::Disconnected || err.status == TransportStatus::AccessDenied) break;
    }
    result.stage = err.stage;
    result.transport = err.status;
    result.message = "firmware upload failed after " + std::to_string(result.attempts_used) + " attempt(s), stage '" +
                     std::string(to_string(err.stage)) + "': " + err.what;
    return result;
}

std::vector<std::uint8_t> read_firmware_file(const std::string& path, std::string& error) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        error = "cannot open the Falcon firmware file '" + path + "'";
        return {};
    }
    std::vector<std::uint8_t> data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (data.empty()) error = "the Falcon firmware file '" + path + "' is empty";
    return data;
}

}  // namespace hapticd::falcon
