#include "preview.h"

#include "atomicfile.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

/* IEC 61966-2-1 sRGB encoding of a linear value in [0, 1]. */
static unsigned char srgb8(float linear)
{
    float c = linear < 0.f ? 0.f : (linear > 1.f ? 1.f : linear);
    float e = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.f / 2.4f) - 0.055f;
    return (unsigned char)std::lround(e * 255.f);
}

static int fail(rr_error *err, const std::string &what)
{
    return rr_fail(err, "%s", what.c_str());
}

static std::string extension_of(const std::string &p)
{
    size_t slash = p.rfind('/'), dot = p.rfind('.');
    return dot != std::string::npos && (slash == std::string::npos || dot > slash) ? p.substr(dot) : std::string();
}

extern "C" int preview_check_format(const char *path, rr_error *err)
{
    std::string ext = extension_of(path);
    auto out = OIIO::ImageOutput::create(ext.empty() ? std::string("none") : ext.substr(1));
    if (!out)
        return fail(err, std::string(path) + ": no image format for the extension '" + ext +
                                       "' (use e.g. .png)");
    if (!out->supports("ioproxy"))
        return fail(err, std::string(path) + ": OpenImageIO cannot write '" + ext +
                                       "' through memory, which refrender needs to check every write (use .png)");
    return 0;
}

/* Encodes the image in memory: OpenImageIO's PNG writer does not report a
 * full disk (libpng ignores fwrite's result), so the bytes are written to
 * the file by write_all below, which checks every write. */
static bool encode(const std::string &path, int w, int h, const std::vector<unsigned char> &px,
                   std::vector<unsigned char> &bytes, std::string &why)
{
    auto out = OIIO::ImageOutput::create(path); /* a format preview_check_format accepted */
    if (!out) {
        why = OIIO::geterror();
        return false;
    }
    OIIO::Filesystem::IOVecOutput memory(bytes);
    OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    bool ok = out->set_ioproxy(&memory) && out->open(path, spec) &&
              out->write_image(OIIO::TypeDesc::UINT8, px.data());
    ok = out->close() && ok;
    if (!ok)
        why = out->geterror();
    return ok;
}

static bool write_all(const char *name, const std::vector<unsigned char> &bytes)
{
    FILE *f = std::fopen(name, "wb");
    if (!f)
        return false;
    bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
    ok = std::fflush(f) == 0 && ok;
    return std::fclose(f) == 0 && ok;
}

extern "C" int preview_write_srgb(const char *path, int w, int h, const float *rgba, rr_error *err)
{
    std::string p(path), why;
    if (preview_check_format(path, err))
        return -1;
    std::vector<unsigned char> px((size_t)w * h * 3), bytes;
    for (size_t i = 0; i < (size_t)w * h; i++)
        for (int c = 0; c < 3; c++)
            px[3 * i + c] = srgb8(rgba[4 * i + c]);
    if (!encode(p, w, h, px, bytes, why))
        return fail(err, p + ": cannot encode preview: " + why);
    std::vector<char> name(p.size() + 128);
    if (atomic_create(path, extension_of(p).c_str(), name.data(), name.size(), err))
        return -1;
    if (!write_all(name.data(), bytes)) {
        atomic_discard(name.data());
        return fail(err, p + ": cannot write preview (disk full?)");
    }
    return atomic_commit(name.data(), path, err);
}
