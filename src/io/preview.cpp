/* The preview module (refrender-preview.so): OpenImageIO's encoders behind
 * a C interface, loaded by preview.c only when a preview is asked for.
 * OpenImageIO links some 260 shared libraries; linked into refrender it
 * cost every run 0.4 s of symbol lookup before main (and the test suite
 * starts refrender over a thousand times). Depends on nothing of
 * refrender's: errors come back as text. */
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

extern "C" int rr_preview_encode(const char *path, int w, int h, const unsigned char *rgb, unsigned char **bytes,
                                 size_t *len, char *why, size_t why_size);

static void say(char *why, size_t n, const std::string &what) { std::snprintf(why, n, "%s", what.c_str()); }

/* Whether OpenImageIO reads back, at its size, a small image its writer
 * for ext encoded in memory: OpenImageIO 2.4's TIFF writer through memory
 * leaves a 324-byte file without its directory ("missing required
 * ImageLength"), which only a read shows. */
static bool reads_back(const std::string &ext)
{
    const int w = 3, h = 2;
    unsigned char rgb[w * h * 3] = {0, 64, 128, 255};
    unsigned char *bytes = nullptr;
    size_t len = 0;
    char why[256];
    std::string name = "trial." + ext;
    if (rr_preview_encode(name.c_str(), w, h, rgb, &bytes, &len, why, sizeof why))
        return false;
    OIIO::Filesystem::IOMemReader reader(bytes, len);
    auto in = OIIO::ImageInput::open(name, nullptr, &reader);
    bool ok = in && in->spec().width == w && in->spec().height == h;
    if (in)
        in->close();
    OIIO::geterror(); /* a failed open's message is not ours to keep */
    std::free(bytes);
    return ok;
}

/* 0: OpenImageIO writes format ext ("png", no dot) through memory; 1: no
 * writer for it; 2: a writer that cannot write to memory; 3: one whose
 * output it cannot read back. */
extern "C" int rr_preview_format(const char *ext)
{
    auto out = OIIO::ImageOutput::create(*ext ? std::string(ext) : std::string("none"));
    if (!out)
        return 1;
    if (!out->supports("ioproxy"))
        return 2;
    return reads_back(ext) ? 0 : 3;
}

/* Encodes 8-bit RGB as the format of path's name, in memory (OpenImageIO's
 * PNG writer does not report a full disk: libpng ignores fwrite's result,
 * so preview.c writes the bytes and checks every write). *bytes is
 * malloc'd; 0, or -1 with the reason in why. */
extern "C" int rr_preview_encode(const char *path, int w, int h, const unsigned char *rgb, unsigned char **bytes,
                                 size_t *len, char *why, size_t why_size)
{
    auto out = OIIO::ImageOutput::create(path); /* a format rr_preview_format accepted */
    if (!out) {
        say(why, why_size, OIIO::geterror());
        return -1;
    }
    std::vector<unsigned char> memory_bytes;
    OIIO::Filesystem::IOVecOutput memory(memory_bytes);
    OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    bool ok = out->set_ioproxy(&memory) && out->open(path, spec) && out->write_image(OIIO::TypeDesc::UINT8, rgb);
    ok = out->close() && ok;
    if (!ok) {
        say(why, why_size, out->geterror());
        return -1;
    }
    *bytes = (unsigned char *)std::malloc(memory_bytes.size() + 1);
    if (!*bytes) {
        say(why, why_size, "out of memory");
        return -1;
    }
    std::memcpy(*bytes, memory_bytes.data(), memory_bytes.size());
    *len = memory_bytes.size();
    return 0;
}
