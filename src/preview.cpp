#include "preview.h"

#include <OpenImageIO/imageio.h>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

/* IEC 61966-2-1 sRGB encoding of a linear value in [0, 1]. */
static unsigned char srgb8(float linear)
{
    float c = linear < 0.f ? 0.f : (linear > 1.f ? 1.f : linear);
    float e = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.f / 2.4f) - 0.055f;
    return (unsigned char)std::lround(e * 255.f);
}

static int fail(char *msg, int size, const std::string &what)
{
    std::snprintf(msg, (size_t)size, "%s", what.c_str());
    return -1;
}

extern "C" int preview_write_srgb(const char *path, int w, int h, const float *rgba, char *msg, int msg_size)
{
    std::string p(path);
    std::string ext = p.find('.') != std::string::npos ? p.substr(p.rfind('.')) : std::string(".png");
    std::string tmp = p + ".tmp-XXXXXX" + ext;
    std::vector<char> name(tmp.begin(), tmp.end());
    name.push_back('\0');
    int fd = mkstemps(name.data(), (int)ext.size());
    if (fd < 0)
        return fail(msg, msg_size, p + ": cannot create a temporary file beside the preview");
    mode_t mask = umask(0); /* mkstemps makes the file private; use the umask */
    umask(mask);
    fchmod(fd, 0666 & ~mask);
    close(fd);
    std::vector<unsigned char> px((size_t)w * h * 3);
    for (size_t i = 0; i < (size_t)w * h; i++)
        for (int c = 0; c < 3; c++)
            px[3 * i + c] = srgb8(rgba[4 * i + c]);
    auto out = OIIO::ImageOutput::create(name.data());
    OIIO::ImageSpec spec(w, h, 3, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    bool ok = out && out->open(name.data(), spec) && out->write_image(OIIO::TypeDesc::UINT8, px.data());
    std::string why = out ? out->geterror() : OIIO::geterror();
    if (out)
        ok = out->close() && ok;
    if (!ok || std::rename(name.data(), path) != 0) {
        unlink(name.data());
        return fail(msg, msg_size, p + ": cannot write preview: " + why);
    }
    return 0;
}
